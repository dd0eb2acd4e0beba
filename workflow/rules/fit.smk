# Virtual Rotor Inertia: lambda (eq 11, 15) per gain class of the paper (zero_low, high)
# from the fixed-base trials of every configuration, with bootstrap intervals and the
# identifiability findings (campaign.joints.lambda_fit.LambdaFit).


rule fit_lambda:
    input:
        tables=lambda wc: ident_tables("fixed", gains=fit_classes()[wc.gain_class]),
    output:
        json=f"{RESULTS}/fit/lambda_{{gain_class}}.json",
    params:
        code=CODE_FIT,
        gains=lambda wc: fit_classes()[wc.gain_class],
        options=config["fit"],
        seed=config["campaign_seed"],
    wildcard_constraints:
        gain_class="|".join(GAIN_CLASSES),
    # scheduling: jobs that unlock others and long ones first, so a run ends on short jobs
    priority: 1
    log:
        log_file("fit_lambda", "{gain_class}"),
    benchmark:
        bench_file("fit_lambda", "{gain_class}")
    resources:
        runtime=10,
        mem_mb=1000,
    conda:
        "../envs/campaign.yaml"
    script:
        "../scripts/fit_lambda.py"
