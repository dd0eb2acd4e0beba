"""The reduced numerical-stability stress set: every corner either passes its
invariants or is refused before simulating with a message naming the cause.

The full grid is ``campaign bench stress``; its reduced set
(``campaign.bench.stress_cases(reduced=True)``) and the closed-form stress run here once,
as ``campaign bench stress --reduced`` through the CLI (:func:`stress_run`), and the tests
read the command's output and the results it computed; a refusal must name its cause
(``REFUSAL_CAUSE``).
"""

from __future__ import annotations

import contextlib
import io
import math
import re
from types import SimpleNamespace

import numpy as np
import pytest

from campaign import bench
from campaign.bench.closed_form import _q_dh, singular_pose
from campaign.bench.common import XARRAY_WRITE_AT_TARGETS
from campaign.bench.stress import ENERGY_RTOL
from campaign.cli.main import main
from campaign.model import exiit
from campaign.model.robot import load_robot

CASES = bench.stress_cases(reduced=True)

#: what a refusal's message must name, per case
REFUSAL_CAUSE = {
    "q3 0.01 deg beyond +135 limit": "outside its limits",
    "1000x High": "unstable at the servo rate",
    "10 m/s, zero": "beyond what the pendulum can reach",
    "EI 10000x, loop": "first-mode frequency",
    "stiffness 0.01x, zero": "outlasts the recording",
    "m_b = 100x m*, configuration 2": "keep pushing the arm",
    "ideal contact, substeps_contact=1": "RK4 steps over a contact",
    "EI 100x, ideal": "highest mode",
    "VES bandwidth 300 Hz": "loop is unstable",
}

#: the last line of ``campaign bench stress``
SUMMARY_LINE = re.compile(r"^(\d+) cases: (\d+) passed \((\d+) excluded by identification\), (\d+) refused "
                          r"with a reason, (\d+) reported blow-ups, (\d+) failed$")


def _param(case):
    return pytest.param(case, id=f"{case.axis}: {case.label}")


def _recording(computed: dict, name: str, fn):
    """``fn``, keeping what it returns under ``computed[name]``."""
    def call(*args, **kwargs):
        computed[name] = fn(*args, **kwargs)
        return computed[name]
    return call


def _run_cli(argv: list[str], folder) -> SimpleNamespace:
    """``campaign ARGV`` through :func:`campaign.cli.main.main` in ``folder``: its exit status,
    stdout, stderr, the folder, and the stress results and closed-form stress it computed."""
    computed: dict = {}
    out, err = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bench, "run_stress", _recording(computed, "results", bench.run_stress))
        mp.setattr(bench, "closed_form_stress", _recording(computed, "closed_form", bench.closed_form_stress))
        mp.setenv("CAMPAIGN_PROGRESS", "0")
        mp.chdir(folder)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = main(argv)
    return SimpleNamespace(status=status, out=out.getvalue(), err=err.getvalue(), folder=folder, **computed)


@pytest.fixture(scope="module")
def stress_run(tmp_path_factory):
    """``campaign bench stress --reduced``, run once through the CLI."""
    return _run_cli(["bench", "stress", "--reduced"], tmp_path_factory.mktemp("stress"))


def test_the_reduced_set_covers_every_axis_of_the_grid():
    axes = {c.axis for c in CASES}
    assert {"pose", "gains", "contact", "speed", "hammer", "servo", "integration", "beam"} <= axes
    assert set(REFUSAL_CAUSE) <= {c.label for c in CASES}
    assert len({c.label for c in CASES}) == len(CASES)          # a label names one case


def test_the_command_runs_every_case_prints_its_tables_and_exits_0(stress_run):
    assert stress_run.status == 0, stress_run.err[-2000:]
    results = stress_run.results
    assert [r.case.label for r in results] == [c.label for c in CASES]
    lines = stress_run.out.splitlines()
    assert lines[0].startswith("| cases run | passed | (of which identification excluded) |")
    for header in ("| axis | run | passed | refused | blow-up | failed |",
                   "| axis | case | outcome | time [s] | reason / note | measured |"):
        assert header in lines
    for r in results:       # a row per case with its outcome, a progress line per case on stderr
        assert any(line.startswith(f"| {r.case.axis} | {r.case.label} | {r.status} |") for line in lines), r.case.label
        assert f"{r.case.axis}: {r.case.label}" in stress_run.err
    for axis in {c.axis for c in CASES}:
        n = sum(c.axis == axis for c in CASES)
        assert any(line.startswith(f"| {axis} | {n} |") for line in lines), axis
    assert "condition number of the sensitivity matrix" in stress_run.out      # the closed-form stress
    counts = SUMMARY_LINE.match(lines[-1])
    assert counts, lines[-1]
    s = bench.stress_summary(results)
    assert [int(x) for x in counts.groups()] == [s[k] for k in ("run", "passed", "excluded", "refused", "blow-up",
                                                                 "failed")]
    assert s["run"] == len(CASES) and s["passed"] + s["refused"] == len(CASES)
    assert list(stress_run.folder.iterdir()) == []     # the cases' files went to a temporary folder, now gone


@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_corner_passes_its_invariants_or_is_refused_naming_the_cause(case, stress_run):
    res = next(r for r in stress_run.results if r.case.label == case.label)
    # a file left behind turns a case into "failed" (bench.run_case)
    assert res.status in ("passed", "refused"), f"{res.status}: {res.reason}"
    if res.status == "refused":
        assert case.label in REFUSAL_CAUSE, f"unexpected refusal: {res.reason}"
        assert REFUSAL_CAUSE[case.label] in res.reason
    else:
        assert case.label not in REFUSAL_CAUSE, "expected a refusal"


def test_a_failed_case_makes_the_command_exit_1_with_the_count_in_its_last_line(tmp_path, monkeypatch):
    """The exit status follows the results (a failure planted in what the run returns),
    and ``--quiet --no-closed-form`` print the tables alone."""
    case = CASES[0]
    planted = [bench.StressResult(case, "failed", "planted", 0.0, {})]
    monkeypatch.setattr(bench, "stress_cases", lambda **kw: [case])
    monkeypatch.setattr(bench.stress, "run_case", lambda c, folder, **kw: planted[0])
    run = _run_cli(["bench", "stress", "--quiet", "--no-closed-form"], tmp_path)
    assert run.status == 1 and run.err == ""
    assert "condition number" not in run.out and not hasattr(run, "closed_form")
    assert run.out.splitlines()[-1] == ("1 cases: 0 passed (0 excluded by identification), 0 refused with a reason, "
                                        "0 reported blow-ups, 1 failed")


def test_invariants_catch_a_nan_filled_trial_and_an_energy_gain():
    from campaign.identify import identify_trial
    from campaign.rig import simulate
    from campaign.scene.description import make_scene

    scene = make_scene(config=1, scene="ideal", speed=1.5)
    tree = simulate(scene)
    ident = identify_trial(tree["measured"].to_dataset(), meta=dict(tree.attrs))
    viol, info = bench.check_invariants(scene, tree, ident)
    assert viol == [] and info["energy_rise"] <= ENERGY_RTOL
    bad = tree.copy(deep=True)
    f = bad["measured"].to_dataset()
    f["f_piezo"].values[10] = np.nan
    bad["measured"] = f
    assert any("non-finite" in v for v in bench.check_invariants(scene, bad, ident)[0])
    hot = tree.copy(deep=True)
    t = hot["truth"].to_dataset()
    t["energy"].values[-5:] += 1e-3
    hot["truth"] = t
    assert any("energy rises" in v for v in bench.check_invariants(scene, hot, ident)[0])


# -- closed forms ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def singular():
    return singular_pose()


def test_exiit_is_inf_at_the_stretched_singularity_and_grows_finite_towards_it(puma, singular):
    q1, q2, q3 = singular
    Q = np.array([_q_dh((q1, q2, q3 + d)) for d in (1.0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 0.0)])
    for lam in (None, [53.18, 8.66, 2.83]):
        batch = exiit.effective_mass_batch(puma, Q, lam=lam)
        scalar = np.array([exiit.effective_mass(puma, q, lam=lam) for q in Q])
        assert not np.any(np.isnan(batch)) and np.all(batch > 0)
        assert np.isinf(batch[-1]) and np.isinf(scalar[-1])
        finite = np.isfinite(scalar)
        assert np.array_equal(finite, np.isfinite(batch))
        assert np.allclose(batch[finite], scalar[finite], rtol=1e-6)
        assert np.all(np.diff(scalar[finite]) > 0)         # grows monotonically, no garbage jumps


def test_closed_form_stress_reports_no_problem_and_the_paper_designs_conditioning(stress_run):
    c = stress_run.closed_form
    assert c["problems"] == []
    assert c["random"]["bad"] == 0 and c["random"]["mismatches"] == 0
    S = c["sensitivity"]["S"]
    assert np.all(S[:, :2] < 0.05) and np.all(S[:, 2] > 0.4)        # lambda_1, lambda_2 barely act on m*
    assert c["sensitivity"]["cond"] > 100
    fit = c["fit"]
    if fit["available"]:
        rows = {r["design"]: r for r in fit["rows"]}
        for name in ("paper configurations 1-3, 2 % noise", "three poses within 0.01 deg of configuration 2"):
            r = rows[name]
            assert r["cond"] > 1e3 and not r["identifiable"][:2].any(), name
            assert np.all(np.isfinite(r["lam"]))


def test_lambda_fit_on_a_single_pose_flags_every_component():
    from campaign.joints import lambda_fit as fitmod
    robot = load_robot()
    q = _q_dh((0.0, 172.0, 40.0))
    Q = np.repeat(q[None, :], 5, axis=0)
    m = exiit.effective_mass(robot, q, lam=[53.18, 8.66, 2.83]) * np.exp(np.random.default_rng(0).normal(0, .02, 5))
    est = fitmod.LambdaFit(robot, n_bootstrap=30, random_state=1, warn=False).fit(Q, m)
    assert math.isinf(est.condition_number_)
    assert not np.any(est.identifiable_)


def test_cost_verdict_scales_by_the_write_reference_of_the_same_run():
    """The per-trial verdict: met in absolute terms, met only once scaled to the machine the
    targets were set on (this run's xarray write probe against the ~35 ms where the targets were set), or missed;
    the note says how fast the machine ran and does not scale by the naive RK4."""
    def cost(sim_fixed, probe):
        factor = probe / XARRAY_WRITE_AT_TARGETS
        return {"sim": {"fixed": sim_fixed}, "sim_n": {"fixed": 3}, "sim_range": {"fixed": (sim_fixed, sim_fixed)},
                "sim_scaled": {"fixed": sim_fixed / factor}, "probe_xarray": (probe, probe, probe),
                "probe_h5py": (0.003, 0.002, 0.004),
                "per_gain": {("fixed", "zero"): sim_fixed}, "write": {"fixed": 0.06}, "identify": 0.03, "skipped": [],
                "write_scaled": {"fixed": 0.06 / factor},
                "baseline": {"naive_integration": 0.7, "naive_trial": 0.8, "ours_same_scene": sim_fixed,
                             "uniform_0p1ms": 0.2}}
    row = lambda text: next(line for line in text.splitlines() if line.startswith("| fixed | 3 |"))
    ref = XARRAY_WRITE_AT_TARGETS
    assert "| met;" in row(bench.format_cost(cost(0.020, ref)))
    # a machine twice as slow: 40 ms here is 20 ms there
    assert "met scaled by the write reference" in row(bench.format_cost(cost(0.040, 2 * ref)))
    assert "| 20 |" in row(bench.format_cost(cost(0.040, 2 * ref)))
    assert "| missed;" in row(bench.format_cost(cost(0.040, ref)))
    # the write verdict the same way: 60 ms here is 30 ms there (target 50 ms)
    write_row = lambda text: next(line for line in text.splitlines() if line.startswith("| fixed | **60.0**"))
    assert "met scaled" in write_row(bench.format_cost(cost(0.040, 2 * ref)))
    assert write_row(bench.format_cost(cost(0.040, ref))).endswith("| missed |")
    # the note reports the machine's ratio, and calls the raw times the targets' only when close
    assert "ran at 1.00x" in bench.format_cost(cost(0.040, ref))
    assert "raw times are what the targets mean" in bench.format_cost(cost(0.040, ref))
    assert "raw times are what the targets mean" not in bench.format_cost(cost(0.040, 2 * ref))
    assert "2.0x the targets' 350 ms" in bench.format_cost(cost(0.040, ref))


def test_write_probe_times_both_references():
    """The machine probe writes a real group both ways and returns positive medians."""
    probe = bench.write_probe(repeats=1, samples=20)
    assert set(probe) == {"xarray", "h5py"}
    assert all(0.0 < v < 5.0 for v in probe.values()), probe
