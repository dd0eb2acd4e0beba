"""The designed campaign's check of its refitted response model against the shipped one:
byte for byte on one machine, the same numbers within the tolerance policy on another."""

from __future__ import annotations

import json
import shutil

from campaign.design import compare_shipped
from campaign.joints.modelfile import shipped_model_path


def _edited(tmp_path, edit):
    body = json.loads(shipped_model_path().read_text())
    edit(body)
    path = tmp_path / "fitted.json"
    path.write_text(json.dumps(body, indent=1))
    return path


def test_the_same_bytes_are_identical(tmp_path):
    fitted = tmp_path / "fitted.json"
    shutil.copyfile(shipped_model_path(), fitted)
    assert compare_shipped(fitted, tmp_path / "out.txt", shipped=shipped_model_path())
    assert (tmp_path / "out.txt").read_text().startswith("identical:")


def _roundoff(body):
    # what a refit on another BLAS kernel moves: parameters in their last digits, each
    # residual (a log of an m* ratio) by a few 1e-6 of m*
    body["parameters"]["damping"] = [d * (1 + 3e-9) for d in body["parameters"]["damping"]]
    body["fit"]["residual_scatter"] *= 1 + 2e-6
    for key in list(body["fit"]["residuals"])[:5]:
        body["fit"]["residuals"][key] += 2e-5


def test_a_refit_that_moved_by_roundoff_is_the_same_model(tmp_path, capsys):
    fitted = _edited(tmp_path, _roundoff)
    assert compare_shipped(fitted, tmp_path / "out.txt", shipped=shipped_model_path())
    text = (tmp_path / "out.txt").read_text()
    assert text.startswith("the same model:") and "within the tolerance policy" in text
    assert "fit/residuals/" in text     # the closest to its allowance is named


def test_a_parameter_moved_beyond_the_policy_differs_and_is_named(tmp_path):
    def edit(body):
        _roundoff(body)
        body["parameters"]["damping"][1] *= 1 + 1e-3
    assert not compare_shipped(_edited(tmp_path, edit), tmp_path / "out.txt", shipped=shipped_model_path())
    text = (tmp_path / "out.txt").read_text()
    assert text.startswith("differs:") and "parameters/damping" in text


def test_a_residual_moved_beyond_the_policy_or_changed_text_differs(tmp_path):
    def residual(body):
        key = next(iter(body["fit"]["residuals"]))
        body["fit"]["residuals"][key] += 2e-4       # 0.02 % of m*: more than identification moves
    assert not compare_shipped(_edited(tmp_path, residual), tmp_path / "a.txt", shipped=shipped_model_path())

    def option(body):
        body["options"] = {**body.get("options", {}), "coupling": "another"}
    assert not compare_shipped(_edited(tmp_path, option), tmp_path / "b.txt", shipped=shipped_model_path())
    assert "options/coupling" in (tmp_path / "b.txt").read_text()
