# Calibration. `snakemake calibrate` re-fits the unpublished rig parameters to the
# paper's fixed-base observations and rewrites the rig file (everything downstream then
# reruns); it is never part of `all`. The calibration report (fitted and held-out
# observations) is made with Table 4 by the flexible_base job (flexible_base.smk).


rule calibrate:
    input:
        calibration=PLAN.calibration_settings,
    output:
        md=PLAN.calibration_file("fit"),
    log:
        PLAN.log_file("calibrate"),
    params:
        rig=PLAN.rig_file,
    resources:
        runtime=60,
        mem_mb=2000,
    conda:
        "../envs/campaign.yaml"
    shell:
        "campaign calibrate --calibration {input.calibration} --rig {params.rig} "
        "--report $(dirname {output.md}) > {output.md} 2> {log}"
