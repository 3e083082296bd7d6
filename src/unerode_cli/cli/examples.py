"""The examples shown at the end of each subcommand's ``--help``: real command lines, run from
the root of the unerode-cli checkout, on its ``sample_dems/``, ``pipelines/`` and the shared data
beside it (``../shared/data``). Each example is a list of lines: the first starts with
``unerode-cli NAME``, the others continue it (the lines before them end with `` \\``); an example
whose input is written by an earlier one of the same command comes after it.

Kept in one table so that a test can show every example in ``--help`` and run those of the
fast commands.
"""

from __future__ import annotations

#: Examples of each subcommand (``pipeline run`` included): name → examples, each a list of lines.
EXAMPLES: dict[str, list[list[str]]] = {
    "info": [
        ["unerode-cli info sample_dems/coast_wgs84_30m.tif"],
        ["unerode-cli info sample_dems/fractal_30m.exr --json"],
    ],
    "convert": [
        ["unerode-cli convert sample_dems/valley_utm32n_30m.tif valley.asc"],
        ["unerode-cli convert sample_dems/fractal_30m.exr fractal_90m.tif \\",
         "    --cell-size 90 --cog"],
    ],
    "preview": [
        ["unerode-cli preview sample_dems/valley_utm32n_30m.tif valley.png \\",
         "    --exaggeration 2"],
    ],
    "synth": [
        ["unerode-cli synth valley.tif --kind mountain --size 128 --dx 30 --seed 1"],
        ["unerode-cli synth noise.exr --kind fractal --relief 800 --seed 3"],
    ],
    "flow": [
        ["unerode-cli flow sample_dems/eroded_utm32n_30m.tif discharge.tif \\",
         "    --sea-level 0 --outlets S --preview discharge.png"],
    ],
    "erode": [
        ["unerode-cli erode sample_dems/eroded_utm32n_30m.tif future.tif \\",
         "    --process fluvial,thermal --dt 1000 --steps 20 --uplift 5e-4"],
    ],
    "unerode": [
        ["unerode-cli unerode sample_dems/eroded_utm32n_30m.tif past.tif \\",
         "    --process thermal,fluvial --dt 500 --steps 20"],
    ],
    "diff": [
        ["unerode-cli diff sample_dems/valley_utm32n_30m.tif \\",
         "    sample_dems/eroded_utm32n_30m.tif difference.tif --preview diff.png"],
    ],
    "hypsometry": [
        ["unerode-cli hypsometry sample_dems/valley_utm32n_30m.tif \\",
         "    sample_dems/eroded_utm32n_30m.tif --plot hypsometry.png --csv hyps.csv"],
    ],
    "glaciate": [
        ["unerode-cli glaciate sample_dems/valley_utm32n_30m.tif glaciated.tif \\",
         "    --ela 1500 --duration 200 --dt 25 --iceflow sia --ice ice.tif"],
    ],
    "climate-run": [
        ["unerode-cli climate-run sample_dems/eroded_utm32n_30m.tif past.tif \\",
         "    --chronology ../shared/data/lr04/LR04stack.txt --to 20 --dt 5000 \\",
         "    --snapshots 10"],
    ],
    "compare-terraces": [
        ["unerode-cli climate-run sample_dems/eroded_utm32n_30m.tif past.tif \\",
         "    --chronology ../shared/data/lr04/LR04stack.txt --to 20 --dt 5000 \\",
         "    --snapshots 10"],
        ["unerode-cli compare-terraces --present sample_dems/eroded_utm32n_30m.tif \\",
         "    --snapshots past_10ka.tif --snapshots past.tif --auto-river \\",
         "    --observations terraces.csv --out terraces"],
    ],
    "particle-erode": [
        ["unerode-cli particle-erode sample_dems/valley_utm32n_30m.tif rain.tif \\",
         "    --particles 20000 --iterations 5 --seed 1"],
    ],
    "landforms": [
        ["unerode-cli landforms sample_dems/eroded_utm32n_30m.tif --out landforms"],
    ],
    "sandstone": [
        ["unerode-cli sandstone arch arch_out --particles 20000 --frames 40"],
    ],
    "ensemble": [
        ["unerode-cli ensemble pipelines/tautavel_ensemble.yaml \\",
         "    pipelines/runs/tautavel_ensemble/out --members 8 --seed 1 --report"],
        ["unerode-cli ensemble pipelines/tautavel_ensemble.yaml \\",
         "    pipelines/runs/tautavel_ensemble/out --members 8 --seed 1 --resume"],
    ],
    "report": [
        ["unerode-cli climate-run sample_dems/eroded_utm32n_30m.tif past.tif \\",
         "    --chronology ../shared/data/lr04/LR04stack.txt --to 20 --dt 5000 \\",
         "    --snapshots 10"],
        ["unerode-cli report . --output report.html"],
    ],
    "pipeline run": [
        ["unerode-cli pipeline run pipelines/last_glacial_cycle.yaml --dry-run"],
        ["unerode-cli pipeline run pipelines/last_glacial_cycle.yaml --resume"],
        ["unerode-cli pipeline run pipelines/last_glacial_cycle.yaml --resume \\",
         "    --var to=60"],
    ],
}

#: What the examples of a command are, when it needs a word (shown above them).
NOTES = {
    "compare-terraces": ("(the first writes the snapshots that the second compares with the dated "
                         "terraces of terraces.csv, rows name,age_ka,height_above_river_m such as "
                         "young,10,3)"),
    "ensemble": ("(the Tautavel case, 32 members; make -C pipelines ensemble writes its inputs "
                 "first and runs the first; the second resumes an interrupted run)"),
    "report": "(the first writes the run that the second reports on)",
}


def epilog(name: str, extra: str = "") -> str:
    """The end of ``unerode-cli NAME --help``: "Examples (from the checkout's folder):" and the
    examples, then ``extra`` (more text, already laid out)."""
    note = f" {NOTES[name]}" if name in NOTES else ""
    blocks = ["\n".join(f"  {line}" for line in example) for example in EXAMPLES[name]]
    # the first line empty: typer dedents the lines after the first one (they keep their indent)
    text = f"\nExamples, run from the unerode-cli checkout's folder{note}:\n\n" + "\n\n".join(blocks) + "\n"
    return f"{text}\n{extra}" if extra else text


def command_line(example: list[str]) -> str:
    """One example as one command line (its continued lines joined)."""
    return " ".join(line.rstrip("\\").strip() for line in example)
