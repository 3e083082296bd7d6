"""`unerode-cli glaciate DEM OUT`: glaciers grow on a DEM and erode its bed (001 §3–6)."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    POSITIVE_YEARS,
    Band,
    Channel,
    CheckpointEvery,
    Cog,
    CreationOptions,
    Dtype,
    DtypeOpt,
    InputDem,
    MaxSteps,
    Overwrite,
    Preview,
    Quiet,
    Resume,
    Verbose,
)
from unerode_cli.cli.parameter_options import with_parameter_options
from unerode_cli.cli.values import Number
from unerode_cli.glacier import coupled, cycle, erosion, massbalance


class IceFlow(str, Enum):
    blatter = "blatter"
    sia = "sia"


class Transport(str, Enum):
    multiscale = "multiscale"
    explicit = "explicit"


class Edges(str, Enum):
    open = "open"
    periodic = "periodic"


PARAMETER_PANELS = {
    "Mass balance (001 Eq. 2)": tuple(s for s in massbalance.PARAMETERS if s.name != "ela"),
    "Glacial erosion (001 §6.1)": erosion.PARAMETERS,
    "Ice-free ground (001 §6.2–6.4) and uplift": cycle.PARAMETERS,
}
GROUND_PANEL = "Ice-free ground (001 §6.2–6.4) and uplift"
FLOW_PANEL = "Ice flow (001 §3–4)"
OUTPUT_PANEL = "Side outputs"
CHRONOLOGY_PANEL = "ELA from a chronology"


class ElaKind(str, Enum):
    d18o = "d18o"
    sea_level = "sea-level"
    temperature = "temperature"


@with_parameter_options(PARAMETER_PANELS)
def glaciate(
    dem: InputDem,
    output: Annotated[Path | None, typer.Argument(help="Output bedrock after glacial erosion (format from the extension). Optional with --diagnostic, where it receives the bed unchanged with the solver statistics in its sidecar.")] = None,
    ela: Annotated[str | None, typer.Option("--ela", help="Equilibrium-line altitude E (m, 001 Eq. 2): a number, a raster on the DEM's grid, or a CSV table with columns time (years since the start) and ela (m), interpolated linearly.")] = None,
    duration: Annotated[float | None, typer.Option(parser=POSITIVE_YEARS, help="Simulated time (years).")] = None,
    dt: Annotated[float, typer.Option("--dt", parser=POSITIVE_YEARS, help="Time step (years). Multi-scale transport starts from 10 y and grows ×1.5 per step up to it.")] = 10.0,
    iceflow: Annotated[IceFlow, typer.Option(help="Ice flow: blatter (Blatter–Pattyn energy, 001 Eq. 7) or sia (shallow ice + Weertman sliding, fast baseline).", rich_help_panel=FLOW_PANEL)] = IceFlow.blatter,
    layers: Annotated[int, typer.Option("--layers", min=1, help="Layers N of the ice-flow lattice (001 §4.2), ≥ 1.", rich_help_panel=FLOW_PANEL)] = 10,
    sliding_c: Annotated[str, typer.Option("--sliding-C", help="Sliding coefficient C (Pa·(y/m)^(σ-1), 001 Eq. 6): a number, a raster on the DEM's grid, or inf (frozen bed, no sliding, no erosion). The default 2e4 slides 25 m/y under a basal drag of 100 kPa, as measured on Alpine glaciers; values of 1e3 or less make real terrain slide at km/y.", rich_help_panel=FLOW_PANEL)] = "2e4",
    sliding_sigma: Annotated[float, typer.Option("--sliding-sigma", parser=Number(minimum=1.0), help="Sliding exponent σ (001 Table 1: 1.5; 2 = the linear law τ_b = C·u_b of ISMIP-HOM C/D).", rich_help_panel=FLOW_PANEL)] = 1.5,
    rate_factor: Annotated[float | None, typer.Option("--rate-factor", parser=Number("Pa⁻³/y", 0.0, above=True), help="Glen's rate factor A (Pa⁻³/y, n = 3) instead of 001's B; default 8.2e-17, i.e. B = 2.9e5 Pa·y^(1/3) (001 Table 1). ISMIP-HOM: 1e-16.", rich_help_panel=FLOW_PANEL)] = None,
    boundary: Annotated[Edges, typer.Option(help="Domain edges: open (stress free, ice leaves) or periodic (wrap around, e.g. ISMIP-HOM).", rich_help_panel=FLOW_PANEL)] = Edges.open,
    background_slope: Annotated[float, typer.Option("--background-slope", parser=Number("degrees"), help="Uniform inclination (degrees) along +x (east) added to bed and surface, for periodic tilted slabs (ISMIP-HOM: 0.5).", rich_help_panel=FLOW_PANEL)] = 0.0,
    transport: Annotated[Transport, typer.Option(help="Ice transport (001 Eq. 1): multiscale (adaptive long steps, 001 §5) or explicit (sub-stepped at the stability limit).")] = Transport.multiscale,
    transport_cfl: Annotated[float, typer.Option("--transport-cfl", parser=Number(minimum=0.0, maximum=1.0, above=True), help="CFL number c of the multi-scale local step (001 §5: 0.1). Under thick fast ice (an ice sheet of 250 m cells) 0.05 keeps one-cell grooves from growing into a divergence; where the ice moves, steps then go half as far towards its steady state.")] = coupled.MULTISCALE_CFL,
    no_substep: Annotated[bool, typer.Option("--no-substep", help="With --transport explicit: refuse a --dt above the stability limit instead of sub-stepping it.")] = False,
    erode: Annotated[bool, typer.Option("--erosion/--no-erosion", help="Erode the bed by abrasion and quarrying under the sliding ice (001 §6.1).")] = True,
    no_hillslope: Annotated[bool, typer.Option("--no-hillslope", help="Switch off hill-slope diffusion (001 §6.4), which acts where the ice is thin.", rich_help_panel=GROUND_PANEL)] = False,
    no_debris: Annotated[bool, typer.Option("--no-debris", help="Switch off debris flow (001 Eq. 8), which acts where the ice is thin.", rich_help_panel=GROUND_PANEL)] = False,
    no_fluvial: Annotated[bool, typer.Option("--no-fluvial", help="Switch off fluvial erosion k_f·A^m·S^n (001 §6.3), which acts where the ice is thin.", rich_help_panel=GROUND_PANEL)] = False,
    shield_thickness: Annotated[float, typer.Option("--shield-thickness", parser=Number("m", 0.0), help="Ice thicker than this (m) shields the bed from the ice-free processes (001 §6: 3 m).", rich_help_panel=GROUND_PANEL)] = cycle.SHIELD_THICKNESS,
    drainage_every: Annotated[int, typer.Option("--drainage-every", min=1, help="Steps between updates of the drainage of debris flow and rivers (001 §6: 20).", rich_help_panel=GROUND_PANEL)] = cycle.DRAINAGE_EVERY,
    ela_chronology: Annotated[Path | None, typer.Option("--ela-chronology", help="Drive the ELA by a paleo-climate chronology (δ18O stack, sea-level curve or temperatures, see --ela-kind) from --from to --to ka, linear in the proxy between --ela-present (0 ka) and --ela-glacial (the last glacial maximum), or by --ela-lapse-rate.", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    ela_kind: Annotated[ElaKind, typer.Option("--ela-kind", help="What the chronology holds: d18o (heavier = colder), sea-level (lower = colder) or temperature.", rich_help_panel=CHRONOLOGY_PANEL)] = ElaKind.d18o,
    ela_present: Annotated[float | None, typer.Option("--ela-present", parser=Number("m"), help="Today's ELA (m): the ELA at 0 ka.", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    ela_glacial: Annotated[float | None, typer.Option("--ela-glacial", parser=Number("m"), help="The ELA at the last glacial maximum (m; the chronology's most glacial value between 14 and 30 ka).", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    ela_lapse_rate: Annotated[float | None, typer.Option("--ela-lapse-rate", parser=Number("m/K", 0.0, above=True), help="With --ela-kind temperature: metres the ELA rises per kelvin of warming (1/0.0065 ≈ 154 m/K).", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    from_ka: Annotated[float | None, typer.Option("--from", parser=Number("ka", 0.0), help="Age (ka) where a chronology-driven run starts.", rich_help_panel=CHRONOLOGY_PANEL)] = None,
    to_ka: Annotated[float, typer.Option("--to", parser=Number("ka", 0.0), help="Age (ka) where it ends (0 = today).", rich_help_panel=CHRONOLOGY_PANEL)] = 0.0,
    ice_thickness: Annotated[Path | None, typer.Option("--ice-thickness", help="Ice thickness (m) on the DEM's grid: the initial ice, or with --diagnostic the geometry to solve.")] = None,
    diagnostic: Annotated[bool, typer.Option("--diagnostic", help="Solve the velocity of DEM + --ice-thickness once (no time stepping, relative residual 1e-5) and write --velocity and --sliding.")] = False,
    ice: Annotated[Path | None, typer.Option("--ice", help="Write the final ice thickness (m).", rich_help_panel=OUTPUT_PANEL)] = None,
    velocity: Annotated[Path | None, typer.Option("--velocity", help="Write the surface velocity (GeoTIFF, 2 bands: vx east, vy along the rows = south; m/y) of the final geometry.", rich_help_panel=OUTPUT_PANEL)] = None,
    sliding: Annotated[Path | None, typer.Option("--sliding", help="Write the basal sliding speed (m/y) of the final geometry.", rich_help_panel=OUTPUT_PANEL)] = None,
    lakes: Annotated[Path | None, typer.Option("--lakes", help="Write the lake depth (m) of the final bed: depressions not filled by ice, to their spill level; count, area and volume in its sidecar.", rich_help_panel=OUTPUT_PANEL)] = None,
    timeline: Annotated[Path | None, typer.Option("--timeline", help="Write a CSV with one row per step: time, age, ELA, ice volume and area, eroded volumes, lake area.", rich_help_panel=OUTPUT_PANEL)] = None,
    snapshot_every: Annotated[float | None, typer.Option(parser=POSITIVE_YEARS, help="Write the ice thickness every this many years: ICE_001.tif, ... after --ice (else OUT_ice_001.tif, ...).", rich_help_panel=OUTPUT_PANEL)] = None,
    band: Band = None,
    channel: Channel = None,
    dtype: DtypeOpt = Dtype.float32,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    checkpoint_every: CheckpointEvery = 100,
    resume: Resume = False,
    max_steps: MaxSteps = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
    parameter_values: dict[str, str | None] | None = None,
) -> None:
    """Grow glaciers on a DEM (mass balance, ice flow, transport) and erode its bed (001). The progress bar shows the simulated years, their rate (y/s) and the time left; -v prints every step with the velocity solver's iterations and residual; OUT's JSON sidecar holds the ice-volume series. An ELA above every peak makes no ice: a note, and the bed is unchanged."""
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.cli.progress import simulated_time_bar
        from unerode_cli.jobs.glaciate import GlacierJob, plan, run_diagnostic, run_job

        job = GlacierJob(
            source=dem, output=output, ela=ela, duration=duration, dt=dt, iceflow=iceflow.value,
            layers=layers, sliding_c=sliding_c, sliding_sigma=sliding_sigma, rate_factor=rate_factor,
            boundary=boundary.value, background_slope=background_slope, transport=transport.value,
            transport_cfl=transport_cfl, allow_substeps=not no_substep, erosion=erode,
            ice_thickness=ice_thickness, ice=ice,
            velocity=velocity, sliding=sliding, snapshot_every=snapshot_every, hillslope=not no_hillslope,
            debris=not no_debris, fluvial=not no_fluvial, shield_thickness=shield_thickness,
            drainage_every=drainage_every, lakes=lakes, timeline=timeline, ela_chronology=ela_chronology,
            ela_kind=ela_kind.value, ela_present=ela_present, ela_glacial=ela_glacial,
            ela_lapse_rate=ela_lapse_rate, from_ka=from_ka, to_ka=to_ka,
            diagnostic=diagnostic,
            band=band, channel=channel, dtype=dtype.value, cog=cog, co=co, overwrite=overwrite,
            preview=preview, checkpoint_every=checkpoint_every, resume=resume, max_steps=max_steps,
            parameter_values=parameter_values or {},
        )
        prepared = plan(job)
        if diagnostic:
            say(run_diagnostic(prepared), verbose - quiet, SUMMARY)
            return
        with simulated_time_bar(float(prepared.times[-1]), "glaciate", verbose - quiet) as advance:
            summary = run_job(prepared, on_step=advance, on_note=lambda text: say(text, verbose - quiet))
        say(summary, verbose - quiet, SUMMARY)
