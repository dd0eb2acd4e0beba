"""Studies: experiments on the simulated rig whose results the user guide and the campaign
report show, each run by the workflow (``snakemake study_<name>``, ``workflow/rules/studies.smk``)
into ``results/studies/<name>/`` as CSV files.

``common``                   what the studies share: one identified trial, lambda, CSV files
``closed_forms``             eq 7 / eq 8 on a trial and their impulsive limits (no fitting libraries)
``space_structure``          Table 4 and Figure 9 under both named structures; eq 8's validity map
``flexible_validation``      why the held-out Table 4 and Figure 9 comparisons miss
``plan_rig_check``           the impact planner's candidates simulated on the rig
``plan_nonlinear_twin``      the planner's linearisation against the arm's nonlinear dynamics
``identification_accuracy``  identified m* and e against the simulator truth
``emulation_error``          the VES-II loop against the ideal coupling
``impact_resistance``        where the joints' resistance comes from, on the designed campaign
``response_model``           the shipped response model on held-out poses, both bases, the planner

Each study module has ``run(out_dir, *, quick=False)``, which writes the files :data:`FILES`
names into ``out_dir`` and returns their paths; ``quick`` runs a reduced set (seconds) for
the tests. This module imports nothing: the workflow reads :data:`FILES` at start-up.
Method and findings: the user guide's *Studies* page (``docs/studies.rst``).
"""

__all__ = ["FILES", "NAMES"]

#: the files each study writes into ``results/studies/<name>/`` (a quick run writes the same
#: files; a part it skips holds only its header)
FILES = {
    "space_structure": ("lambda.csv", "modes.csv", "table4_structures.csv", "fig9_variants.csv", "eq8_validity.csv",
                        "base_fit.csv"),
    "flexible_validation": ("lambda.csv", "lambda_error.csv", "servo_frequencies.csv", "passive_contact.csv",
                            "structure_stiffness.csv", "figure9.csv", "figure9_bases.csv", "figure9_structures.csv",
                            "paper_lambda.csv"),
    "plan_rig_check": ("plan_rig_check.csv", "candidates.csv", "facts.csv", "impulsive_limit.csv", "passive.csv",
                       "coulomb.csv", "sign_asymmetry.csv"),
    "plan_nonlinear_twin": ("twin.csv",),
    "identification_accuracy": ("accuracy.csv", "gap.csv", "ideal.csv"),
    "emulation_error": ("emulation_error.csv", "traces.csv", "emulation_error.png"),
    "impact_resistance": ("lambda.csv", "diagnosis.csv", "ablation.csv"),
    "response_model": ("fixed.csv", "flexible.csv", "planner.csv", "planner_candidates.csv", "summary.csv",
                       "summary.md", "coverage.csv", "coverage.md"),
}
#: the studies, as the workflow's configuration key ``studies:`` names them
NAMES = tuple(FILES)
