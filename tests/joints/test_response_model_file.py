"""Model files: save then load predicts bit for bit, for every kind of the family; a corrupted
file, a schema violation, a missing key, another robot or rig file: one line naming the
problem (ModelFileError), and exit status 2 in the CLI."""

from __future__ import annotations

import copy
import json
import subprocess
import sys

import numpy as np
import pytest

from campaign.joints.estimator import CoulombModel, Eq11Model, LambdaModel
from campaign.joints.impacts import Impacts
from campaign.joints.modelfile import ModelFileError, load_model, model_document, save_model, shipped_model_path
from campaign.joints.setting import Setting
from campaign.model.paper import paper_q

from console_examples import REPO

POSES_DEG = [(0, 150, 90), (30, 200, 60), (-45, 180, 0), (10, 120, 150), (60, 150, 120), (-20, 210, 30)]
DIRS = [(-1, 0, 0), (-0.5, -0.8660254, 0), (0.8660254, 0.5, 0), (0, -1, 0), (-0.7071068, 0.7071068, 0),
        (0.5, -0.8660254, 0)]


@pytest.fixture(scope="module")
def setting():
    return Setting.from_rig()


@pytest.fixture(scope="module")
def impacts():
    Q = np.array([paper_q(np.array(q, float)) for q in POSES_DEG])
    q = np.repeat(Q, 2, axis=0)
    d = np.repeat(np.array(DIRS, float), 2, axis=0)
    gains = ["low", "high"] * len(Q)
    rng = np.random.default_rng(1)
    return Impacts(q=q, direction=d, speed=np.tile([1.5, 2.5], len(Q)), gain=gains,
                   m_eff=rng.uniform(10.0, 40.0, size=len(q)), restitution=np.full(len(q), 0.55),
                   keys=[f"trial{i:02d}.nc" for i in range(len(q))])


@pytest.fixture(scope="module")
def shipped_doc():
    return json.loads(shipped_model_path().read_text(encoding="utf-8"))


def test_save_then_load_predicts_bit_for_bit_for_every_kind(setting, impacts, tmp_path):
    for model in (Eq11Model(setting).fit(impacts), LambdaModel(setting, n_bootstrap=5).fit(impacts),
                  CoulombModel(setting).fit(impacts), load_model(shipped_model_path(), setting=setting)):
        path = save_model(model, tmp_path / f"{model.kind}.json", archive="archive/test")
        again = load_model(path, setting=setting)
        for a, b in zip(model.predict_interval(impacts), again.predict_interval(impacts), strict=True):
            assert np.array_equal(a, b), model.kind
        assert model_document(again, archive="archive/test") == json.loads(path.read_text())


def test_the_shipped_model_records_its_provenance(shipped_doc, setting):
    assert shipped_doc["kind"] == "joint_impedance"
    assert shipped_doc["rig"]["sha256"] == setting.digests["rig"]
    assert shipped_doc["robot"] == {"name": "puma560", "files": setting.digests["robot"]}
    assert shipped_doc["fit"]["archive"] == "archive/designed"
    assert shipped_doc["fit"]["n_trials"] == len(shipped_doc["fit"]["residuals"]) >= 24
    assert set(shipped_doc["fit"]["structure_scatter"]) == {"space_class", "stiff_mast"}
    assert all(k.startswith("archive/designed/") for k in shipped_doc["fit"]["residuals"])


def _broken(doc, edit):
    bad = copy.deepcopy(doc)
    edit(bad)
    return bad


CASES = {
    "another rig file": (lambda d: d["rig"].update(sha256="0" * 64), "fitted for the rig file"),
    "another robot": (lambda d: d["robot"].update(name="planar2"), "fitted for robot 'planar2'"),
    "other robot files": (lambda d: d["robot"]["files"].update({"drives.yaml": "1" * 64}), "other parameter files"),
    "another paper table": (lambda d: d["paper"].update(sha256="2" * 64), "fitted for the paper file"),
    "a missing key": (lambda d: d.pop("fit"), "no key 'fit'"),
    "a wrong type": (lambda d: d.update(parameters=[1, 2]), "key 'parameters' must be a JSON dict"),
    "another schema": (lambda d: d.update(schema="something.else"), "schema 'something.else'"),
    "a newer version": (lambda d: d.update(schema_version=3), "schema version 3"),
    "an unknown kind": (lambda d: d.update(kind="neural_net"), "unknown model kind 'neural_net'"),
    "a missing parameter": (lambda d: d["parameters"].pop("damping"), "parameters.damping must be a list"),
    "a missing parameter of another kind": (lambda d: d.update(kind="lambda", parameters={"lambda": {}},
                                                               options={"n_bootstrap": 5, "random_state": 0}),
                                            "parameters of the lambda model are incomplete or malformed"),
    "no domain": (lambda d: d.pop("domain"), "no key 'domain'"),
    "no digest": (lambda d: d.pop("digest"), "no key 'digest'"),
    "a domain with a reversed speed range": (lambda d: d["domain"].update(speed_m_s=[2.5, 1.5]),
                                             "domain.speed_m_s = [2.5, 1.5] must be two finite numbers"),
    "a domain with an unknown gain set": (lambda d: d["domain"].update(gain_sets=["turbo"]),
                                          "domain.gain_sets names 'turbo'"),
    "edited residuals": (lambda d: d["fit"]["residuals"].update({"archive/designed/x.nc": 0.1}), "residuals for"),
    "a renamed trial": (lambda d: d["fit"].update(residuals={k + "x": v for k, v in d["fit"]["residuals"].items()}),
                        "trial_list_sha256"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_bad_model_file_is_refused_with_one_line_naming_the_problem(case, shipped_doc, setting, tmp_path):
    edit, words = CASES[case]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_broken(shipped_doc, edit)))
    with pytest.raises(ModelFileError) as err:
        load_model(path, setting=setting)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_corrupted_and_missing_files_are_refused(setting, tmp_path):
    path = tmp_path / "model.json"
    path.write_text(shipped_model_path().read_text()[:-400])          # truncated
    with pytest.raises(ModelFileError, match="not valid JSON"):
        load_model(path, setting=setting)
    with pytest.raises(ModelFileError, match="no such model file"):
        load_model(tmp_path / "absent.json", setting=setting)
    path.write_text("[1, 2, 3]")
    with pytest.raises(ModelFileError, match="not a model file"):
        load_model(path, setting=setting)


def test_the_cli_refuses_a_bad_model_file_with_exit_status_2(shipped_doc, tmp_path):
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_broken(shipped_doc, lambda d: d["rig"].update(sha256="0" * 64))))
    for argv in (["meff", "--config", "2", "--model", str(path), "--gain", "high", "--speed", "2"],
                 ["plan", "--point", "-0.6,-0.15,-0.15", "--model", str(path)]):
        r = subprocess.run([sys.executable, "-m", "campaign.cli.main", *argv], capture_output=True, text=True,
                           cwd=REPO)
        assert r.returncode == 2, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and "fitted for the rig file" in lines[0] and r.stdout == ""


def test_a_model_kind_must_define_fit_predict_and_parameters():
    """The family's base class is abstract: a kind that leaves out one of the interface's
    methods cannot be made, and the error names it."""
    from campaign.joints.estimator import ResponseModel

    class Incomplete(ResponseModel):
        kind = "incomplete"

        def fit(self, impacts):
            return self

        def parameters(self):
            return {}

    with pytest.raises(TypeError, match="predict"):
        Incomplete()
