"""Tables 2-4 (campaign.report.tables) and the fit-lambda / tables commands."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from campaign.cli.main import main
from campaign.core.errors import InputError
from campaign.identify import TrialIdentification
from campaign.model.exiit import effective_mass, effective_mass_batch
from campaign.model.paper import configuration_q, load_paper
from campaign.model.robot.floating import BaseBody, attach_to_floating_base
from campaign.report.tables import (
    fit_gain_classes,
    table2,
    table3,
    table4,
    write_tables,
)

from synthetic_impact import cached_trial, write_trial

PAPER = load_paper()
NAN = float("nan")
BASE_INERTIA = (30.0, 0.0, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0, 20.0)


def _rec(config, gain, m, *, base="fixed", excluded=False, repeat=0):
    flex = base == "flexible"
    return TrialIdentification(
        m_eff=m, e=0.55, v_a=0.0, v_a_post=0.1, v_b=2.0, v_b_post=-1.0, impulse=1.3, impulse_momentum=1.3,
        contact_start=0.2, contact_end=0.24, peak_force=50.0, excluded=excluded,
        reason="2 contacts in f_piezo (rebound)" if excluded else "", robot="puma560", base=base, config=config,
        gain=gain, speed=2.0, repeat=repeat, q_cmd=tuple(configuration_q(config)), hammer_mass=0.45,
        impact_direction=(-1.0, 0.0, 0.0), base_mass=120.0 if flex else NAN,
        base_inertia=BASE_INERTIA if flex else (), base_com=(0.0, 0.0, 0.0) if flex else (),
        base_mount=(0.0, 0.0, 0.0) if flex else ())


@pytest.fixture(scope="module")
def records(puma):
    """Fixed-base trials whose m* is eq 11 with the paper's lambda (1 % scatter), an
    excluded outlier, and flexible trials whose m* is eq 8 with the same lambda."""
    rng = np.random.default_rng(0)
    out = []
    for gain in ("zero", "low", "high"):
        lam = PAPER["table3"]["high" if gain == "high" else "zero_low"]
        for config in (1, 2, 3):
            m = effective_mass(puma, configuration_q(config), lam=lam)
            for repeat in range(4):
                out.append(_rec(config, gain, m * np.exp(rng.normal(0, 0.01)), repeat=repeat))
    out.append(_rec(1, "low", 1e6, excluded=True))
    body = BaseBody(mass=120.0, inertia=np.reshape(BASE_INERTIA, (3, 3)))
    fr = attach_to_floating_base(puma, body)
    for gain in ("low", "high"):
        lam = PAPER["table3"]["high" if gain == "high" else "zero_low"]
        for config in (1, 2, 3):
            m = effective_mass(fr, configuration_q(config), lam=lam)
            for repeat in range(2):
                out.append(_rec(config, gain, m * np.exp(rng.normal(0, 0.01)), base="flexible", repeat=repeat))
    return out


@pytest.fixture(scope="module")
def fits(records):
    return fit_gain_classes(records, n_bootstrap=25, random_state=0, warn=False)


def test_table2(records, puma):
    t = table2(records, paper=PAPER)
    rows = {r["config"]: r for r in t.rows}
    assert sorted(rows) == [1, 2, 3]
    m1 = effective_mass_batch(puma, np.array([configuration_q(c) for c in (1, 2, 3)]))
    for k, c in enumerate((1, 2, 3)):
        r = rows[c]
        assert r["m1"] == pytest.approx(m1[k])
        assert r["m1_paper"] == PAPER["table2"]["m1"][c] and r["m3_paper"] == PAPER["table2"]["m3"][c]
        assert r["m1_rel"] == pytest.approx(r["m1"] / r["m1_paper"] - 1)
        assert r["m2_n"] == 8 and r["m3_n"] == 4           # the excluded outlier is not averaged in
        assert r["m2"] == pytest.approx(effective_mass(puma, configuration_q(c), lam=PAPER["table3"]["zero_low"]), rel=0.02)
        assert r["m2_m1"] == pytest.approx(r["m2"] / r["m1"])
        assert r["m3_m1_paper"] == pytest.approx(PAPER["table2"]["m3"][c] / PAPER["table2"]["m1"][c])
    md = t.to_markdown()
    assert "12.98" in md and "paper" in md and "rel. diff" in md


def test_table3(fits, paper=PAPER):
    t = table3(fits, paper=PAPER)
    assert [r["component"] for r in t.rows] == ["lambda_1", "lambda_2", "lambda_3"]
    for cls in ("zero_low", "high"):
        lam3 = t.rows[2][cls]
        assert lam3 == pytest.approx(PAPER["table3"][cls][2], rel=0.05)
        assert t.rows[2][f"{cls}_lo"] <= lam3 <= t.rows[2][f"{cls}_hi"]
        assert t.rows[2][f"{cls}_identifiable"] is True
        assert t.rows[0][f"{cls}_paper"] == PAPER["table3"][cls][0]
    assert any("not identifiable" in n for n in t.notes)


def test_table4_predicts_eq8(records, fits, puma):
    t = table4(records, fits, paper=PAPER)
    keys = [(r["config"], r["gain"]) for r in t.rows]
    assert keys[:4] == [(1, "low"), (1, "high"), (2, "low"), (2, "high")]      # the paper's cells first
    assert (3, "low") in keys and (3, "high") in keys                           # extended table
    body = BaseBody(mass=120.0, inertia=np.reshape(BASE_INERTIA, (3, 3)))
    fr = attach_to_floating_base(puma, body)
    for r in t.rows:
        lam = fits["high" if r["gain"] == "high" else "zero_low"].lambda_
        assert r["predicted"] == pytest.approx(effective_mass(fr, configuration_q(r["config"]), lam=lam))
        assert r["trials"] == 2
        assert abs(r["pred_vs_ident"]) < 0.05
        assert r["in_paper"] == (r["config"] in (1, 2))
    assert t.rows[0]["identified_paper"] == PAPER["table4"]["1-low"]["experiment"]


def test_tables_from_the_fits_json_equal_those_from_the_fitted_estimators(records, fits, tmp_path):
    """Tables 3-4 read the lambda fits back from their JSON (no pickles): same tables."""
    import json

    from campaign.joints.lambda_fit import load_fits

    paths = {}
    for cls, f in fits.items():
        paths[cls] = tmp_path / f"lambda_{cls}.json"
        paths[cls].write_text(json.dumps(f.summary()))
    loaded = load_fits(paths)
    assert table3(loaded, paper=PAPER).to_csv() == table3(fits, paper=PAPER).to_csv()
    assert table3(loaded, paper=PAPER).to_markdown() == table3(fits, paper=PAPER).to_markdown()
    assert table4(records, loaded, paper=PAPER).to_csv() == table4(records, fits, paper=PAPER).to_csv()


def test_is_usable_keeps_trials_with_a_finite_positive_m_eff_that_are_not_excluded():
    from campaign.identify.results import is_usable

    assert is_usable({"excluded": False, "m_eff": 12.5})
    for bad in ({"excluded": True, "m_eff": 12.5}, {"excluded": False, "m_eff": NAN}, {"excluded": False, "m_eff": None},
                {"excluded": False, "m_eff": 0.0}, {"excluded": False, "m_eff": -1.0},
                {"excluded": False, "m_eff": float("inf")}):
        assert not is_usable(bad), bad


def test_the_fit_job_and_the_tables_fit_the_same_trials(records, fits, tmp_path):
    """The workflow's fit job (an identification CSV) and Tables 3-4 (records) leave out the
    same trials: the excluded outlier and a trial without a computable m*."""
    from campaign.identify.table import IDENTIFY_COLUMNS
    from campaign.pipeline.fit import fit_lambda

    def cell(v):
        if isinstance(v, bool):
            return int(v)
        if isinstance(v, (list, tuple)):
            return " ".join(repr(float(x)) for x in v)
        return "" if v is None else v

    rows = [r.to_dict() for r in [*records, _rec(2, "zero", NAN)]]
    table = tmp_path / "ident.csv"
    with table.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(IDENTIFY_COLUMNS)
        w.writerows([cell(r.get(k)) for k in IDENTIFY_COLUMNS] for r in rows)
    for cls, members in PAPER["gain_classes"].items():
        job = fit_lambda([table], tmp_path / f"{cls}.json", gain_class=cls, gains=members,
                         options={"n_bootstrap": 5})
        assert job["n_trials"] == fits[cls].n_trials_ == 12 * len(members)
        assert job["n_excluded"] == (2 if cls == "zero_low" else 0)


def test_write_tables(records, tmp_path):
    paths = write_tables(records, tmp_path, paper=PAPER, n_bootstrap=20)
    for name in ("table2", "table3", "table4"):
        assert paths[name]["csv"].is_file() and paths[name]["md"].is_file()
        rows = list(csv.DictReader(paths[name]["csv"].open()))
        assert rows
    trials = list(csv.DictReader(paths["trials"]["csv"].open()))
    assert len(trials) == len(records)


def test_no_records_is_an_error():
    with pytest.raises(InputError, match="no identification records"):
        write_tables([], "/nonexistent", paper=PAPER)


def test_cli_on_an_archive(tmp_path, capsys):
    """A small archive of synthetic trial files through fit-lambda and tables."""
    lam = tuple(PAPER["table3"]["zero_low"])
    seed = 500
    for config in (1, 2, 3):
        seed += 1
        tr = cached_trial(config=config, speed=2.0, decay="none", lam=lam, seed=seed)
        write_trial(tr, tmp_path / "arch" / f"c{config}" / "v2.0.nc")
    bad = cached_trial(config=1, speed=2.0, decay="none", lam=lam, seed=599, rebound=0.3)
    write_trial(bad, tmp_path / "arch" / "rebound.nc")
    assert main(["fit-lambda", str(tmp_path / "arch"), "--json", "--bootstrap", "30"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["trials"] == 4 and len(out["excluded"]) == 1 and "rebound" in out["excluded"][0]["reason"]
    fz = out["fits"]["zero_low"]
    assert fz["n_trials"] == 3 and fz["lambda"][2] == pytest.approx(lam[2], rel=0.1)
    assert len(fz["sensitivity"]) == 3 and fz["condition_number"] > 100 and fz["warnings"]
    assert main(["fit-lambda", str(tmp_path / "arch"), "--bootstrap", "10"]) == 0
    text = capsys.readouterr().out
    assert "lambda_3" in text and "condition number" in text and "warning:" in text
    assert main(["tables", str(tmp_path / "arch"), "--out", str(tmp_path / "tab"), "--bootstrap", "10"]) == 0
    assert (tmp_path / "tab" / "table2.md").is_file() and (tmp_path / "tab" / "table4.csv").is_file()


def test_cli_bad_archive(tmp_path, capsys):
    assert main(["fit-lambda", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nowhere" in err[0]
    (tmp_path / "empty").mkdir()
    assert main(["tables", str(tmp_path / "empty"), "--out", str(tmp_path / "o")]) == 2
    assert "no trial files" in capsys.readouterr().err
    assert main(["fit-lambda", str(tmp_path / "empty"), "--bootstrap", "-1"]) == 2
