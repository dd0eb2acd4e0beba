# Calibration. `snakemake calibrate` re-fits the unpublished rig parameters to the
# paper's fixed-base observations and rewrites the rig file (everything downstream then
# reruns); it is never part of `all`. The calibration report is: it reads the fit's record
# from the rig file and compares the held-out flexible-base results of this campaign.


rule calibrate:
    input:
        calibration=str(config_file("calibration.yaml")),
    output:
        md=f"{RESULTS}/calibration/fit.md",
    log:
        log_file("calibrate"),
    params:
        rig=RIG_FILE,
    resources:
        runtime=60,
        mem_mb=2000,
    conda:
        "../envs/campaign.yaml"
    shell:
        "campaign calibrate --calibration {input.calibration} --rig {params.rig} "
        "--report $(dirname {output.md}) > {output.md} 2> {log}"


rule calibration_report:
    input:
        unpack(lambda wc: {f"c{c}_{g}": trial_file("flexible", c, g, *figure_pick("fig9"), key="figures.fig9")
                           for c in (1, 2) for g in ("low", "high")}),
        rig=RIG_FILE,
        table4=f"{RESULTS}/tables/table4.csv",
    output:
        md=f"{RESULTS}/calibration/calibration.md",
        html=report(f"{RESULTS}/calibration/calibration.html", caption="../report/calibration.rst",
                    category="Calibration", subcategory="Fitted and held-out observations",
                    labels={"report": "The simulated rig against the paper"}),
        csv=f"{RESULTS}/calibration/calibration.csv",
    log:
        log_file("calibration_report"),
    resources:
        runtime=5,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/calibration_report.py"

