"""Snakemake script of rule fixed_base: the lambda fits, Tables 2-3 and Figures 6-7 from the
fixed-base identification, each product with its own log."""

from campaign.pipeline import job_log

p, out, log = snakemake.params, snakemake.output, snakemake.log  # noqa: F821 - provided by Snakemake
tables = list(snakemake.input.tables)  # noqa: F821
with job_log(log.job, job="fixed_base", exit_process=True) as timer:
    with timer.imports():
        from campaign.model import load_paper
        from campaign.pipeline import fit_lambda, make_table
    for product in p.products:
        with job_log(log[product], job=product, part_of="fixed_base") as part:
            if product.startswith("fit_"):
                gain_class = product[len("fit_"):]
                fit_lambda(tables, out[product], gain_class=gain_class, gains=p.gains[gain_class],
                           options=p.options, seed=p.seed, timer=part)
            elif product.startswith("table"):
                table3 = product == "table3"   # Table 3 from the fits, Table 2 from the identification
                make_table(product, out[f"{product}_csv"], out[f"{product}_md"], ident_tables=[] if table3 else tables,
                           fits={k: out[f"fit_{k}"] for k in p.gains} if table3 else {},
                           out_html=out[f"{product}_html"], timer=part)
            else:
                with part.imports():  # matplotlib: only when a figure is drawn
                    from campaign.report.figures import fig6, fig7
                with part("figure"):
                    figure = {"fig6": fig6, "fig7": fig7}[product]
                    print(figure.make(tables, out[f"{product}_png"], out[f"{product}_pdf"], paper=load_paper()))
