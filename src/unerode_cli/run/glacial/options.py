"""The options of a glacier run (001 §3–6), declared once, and :class:`GlacierRun`, the run
they describe.

``glaciate`` offers every one of them; ``climate-run --process glacial`` builds a
:class:`GlacierRun` from its own options and takes the defaults declared here for the rest.
Defaults and help of the model's options come from the physics modules' constants and
parameter tables (``glacier.blatter``, ``glacier.coupled``, ``glacier.cycle``).
"""

from __future__ import annotations

from pathlib import Path

from unerode_cli.glacier import blatter, cnn_iceflow, coupled, cycle, erosion, massbalance
from unerode_cli.run.common_options import (
    CHECKPOINTS,
    FORCE,
    POSITIVE_YEARS,
    RASTER_OUTPUT,
    READING,
    SNAPSHOTS_NC,
    SOURCE,
    with_default,
)
from unerode_cli.run.declare import Opt, declared, parameter_options
from unerode_cli.run.values import Number

FLOW_PANEL = "Ice flow (001 §3–4)"
GROUND_PANEL = "Ice-free ground (001 §6.2–6.4) and uplift"
SIDE_OUTPUT_PANEL = "Side outputs"
CHRONOLOGY_PANEL = "ELA from a chronology"

#: The glacier model's parameters given as ``--NAME`` (number or raster), by help panel: the mass
#: balance without the ELA (``--ela`` gives it), glacial erosion, the ice-free processes and uplift.
MASS_BALANCE_PARAMETERS = tuple(s for s in massbalance.PARAMETERS if s.name != "ela")
PARAMETER_PANELS = {
    "Mass balance (001 Eq. 2)": MASS_BALANCE_PARAMETERS,
    "Glacial erosion (001 §6.1)": erosion.PARAMETERS,
    GROUND_PANEL: cycle.PARAMETERS,
}
#: The parameters of the glacier step (``glacier.coupled``), and those of the ice-free ground.
MODEL_PARAMETERS = (*MASS_BALANCE_PARAMETERS, *erosion.PARAMETERS)
SURFACE_PARAMETERS = cycle.PARAMETERS
#: The ELA (001 Eq. 2) and the sliding coefficient C (001 Eq. 6) as the physics declares them.
ELA_SPEC = next(s for s in massbalance.PARAMETERS if s.name == "ela")
FLOW_SPECS = {spec.name: spec for spec in blatter.PARAMETERS}
SLIDING_SPEC = FLOW_SPECS["sliding_c"]

OUTPUT = Opt("output", Path, None, "Output bedrock after glacial erosion (format from the extension). "
             "Optional with --diagnostic, where it receives the bed unchanged with the solver statistics "
             "in its sidecar.", argument=True, role="output", record=False)
ELA = Opt("ela", str, None, "Equilibrium-line altitude E (m, 001 Eq. 2): a number, a raster on the DEM's "
          "grid, or a CSV table with columns time (years since the start) and ela (m), interpolated "
          "linearly.")
DURATION = Opt("duration", float, None, "Simulated time (years).", parser=POSITIVE_YEARS,
               record="duration_years")
DT = Opt("dt", float, 10.0, "Time step (years). Multi-scale transport starts from "
         f"{coupled.RAMP_START:g} y and grows ×{coupled.RAMP_FACTOR:g} per step up to it.",
         parser=POSITIVE_YEARS, record="dt_years")

ICE_FLOW = (
    Opt("iceflow", str, "blatter", "Ice flow: blatter (Blatter–Pattyn energy, 001 Eq. 7), sia (shallow "
        "ice + Weertman sliding, fast baseline) or cnn (001 §4: a network trained on the fly on the same "
        "energy predicts the velocities, which the solver then brings to --flow-rtol; needs PyTorch, "
        "pip install 'unerode-cli[cnn]'; slower than blatter on CPUs, docs/glaciate.md).",
        choices=coupled.ICEFLOWS, panel=FLOW_PANEL),
    Opt("seed", int, cnn_iceflow.DEFAULT_SEED, "Seed of the initial weights of the --iceflow cnn network "
        "(the same seed gives the same run, bit for bit, on the same CPU and threads); the other ice "
        "flows draw no random numbers.", minimum=0, panel=FLOW_PANEL),
    Opt("layers", int, FLOW_SPECS["n_layers"].default, "Layers N of the ice-flow lattice (001 §4.2), ≥ 1.",
        minimum=1, panel=FLOW_PANEL),
    Opt("flow_rtol", float, coupled.FLOW_RTOL, "Relative residual ‖∇E‖/‖∇E(0)‖ every Blatter–Pattyn "
        f"velocity solve must reach (default {coupled.FLOW_RTOL:g}: surface and sliding speeds within about "
        "2 % of a converged solve on real DEMs, docs/glaciate.md); a larger value is faster and less "
        "accurate, and the summary counts the solves that miss it.", parser=Number("", 0.0, 0.5, above=True),
        panel=FLOW_PANEL),
    Opt("sliding_c", str, f"{SLIDING_SPEC.default:g}", "Sliding coefficient C (Pa·(y/m)^(σ-1), 001 Eq. 6): "
        "a number, a raster on the DEM's grid, or inf (frozen bed, no sliding, no erosion). The default "
        f"{SLIDING_SPEC.default:g} slides 25 m/y under a basal drag of 100 kPa, as measured on Alpine "
        "glaciers; values of 1e3 or less make real terrain slide at km/y.", flags=("--sliding-C",),
        panel=FLOW_PANEL),
    Opt("sliding_sigma", float, FLOW_SPECS["sigma"].default, "Sliding exponent σ (001 Table 1: 1.5; 2 = the "
        "linear law τ_b = C·u_b of ISMIP-HOM C/D).", parser=Number(minimum=FLOW_SPECS["sigma"].minimum),
        panel=FLOW_PANEL),
    Opt("rate_factor", float, None, "Glen's rate factor A (Pa⁻³/y, n = 3) instead of 001's B; default "
        f"{FLOW_SPECS['glen_a'].default:.2g}, i.e. B = 2.9e5 Pa·y^(1/3) (001 Table 1). "
        "ISMIP-HOM: 1e-16.", parser=Number("Pa⁻³/y", 0.0, above=True), panel=FLOW_PANEL, record=False),
    Opt("boundary", str, "open", "Domain edges: open (stress free, ice leaves) or periodic (wrap around, "
        "e.g. ISMIP-HOM).", choices=("open", "periodic"), panel=FLOW_PANEL),
    Opt("background_slope", float, 0.0, "Uniform inclination (degrees) along +x (east) added to bed and "
        "surface, for periodic tilted slabs (ISMIP-HOM: 0.5).", parser=Number("degrees"), panel=FLOW_PANEL,
        record="background_slope_degrees"),
)
TRANSPORT = (
    Opt("transport", str, "multiscale", "Ice transport (001 Eq. 1): multiscale (adaptive long steps, "
        "001 §5) or explicit (sub-stepped at the stability limit).", choices=("multiscale", "explicit")),
    Opt("transport_cfl", float, coupled.MULTISCALE_CFL, "CFL number c of the multi-scale local step (001 §5: "
        "0.1). Under thick fast ice (an ice sheet of 250 m cells) 0.05 keeps one-cell grooves from growing "
        "into a divergence; where the ice moves, steps then go half as far towards its steady state.",
        parser=Number(minimum=0.0, maximum=1.0, above=True)),
    Opt("no_substep", bool, False, "With --transport explicit: refuse a --dt above the stability limit "
        "instead of sub-stepping it.", kind="flag", record=False),
    Opt("erosion", bool, True, "Erode the bed by abrasion and quarrying under the sliding ice (001 §6.1).",
        kind="flag", off_flag="--no-erosion"),
)
ICE_FREE_GROUND = (
    Opt("no_hillslope", bool, False, "Switch off hill-slope diffusion (001 §6.4), which acts where the ice "
        "is thin.", kind="flag", panel=GROUND_PANEL, record=False),
    Opt("no_debris", bool, False, "Switch off debris flow (001 Eq. 8), which acts where the ice is thin.",
        kind="flag", panel=GROUND_PANEL, record=False),
    Opt("no_fluvial", bool, False, "Switch off fluvial erosion k_f·A^m·S^n (001 §6.3), which acts where the "
        "ice is thin.", kind="flag", panel=GROUND_PANEL, record=False),
    Opt("shield_thickness", float, cycle.SHIELD_THICKNESS, "Ice thicker than this (m) shields the bed from "
        f"the ice-free processes (001 §6: {cycle.SHIELD_THICKNESS:g} m).", parser=Number("m", 0.0),
        panel=GROUND_PANEL, record="shield_thickness_m"),
    Opt("drainage_every", int, cycle.DRAINAGE_EVERY, "Steps between updates of the drainage of debris flow "
        f"and rivers (001 §6: {cycle.DRAINAGE_EVERY}).", minimum=1, panel=GROUND_PANEL),
)
ELA_CHRONOLOGY = (
    Opt("ela_chronology", Path, None, "Drive the ELA by a paleo-climate chronology (δ18O stack, sea-level "
        "curve or temperatures, see --ela-kind) from --from to --to ka, linear in the proxy between "
        "--ela-present (0 ka) and --ela-glacial (the last glacial maximum), or by --ela-lapse-rate.",
        role="input", panel=CHRONOLOGY_PANEL),
    Opt("ela_kind", str, "d18o", "What the chronology holds: d18o (heavier = colder), sea-level (lower = "
        "colder) or temperature.", choices=("d18o", "sea-level", "temperature"), panel=CHRONOLOGY_PANEL),
    Opt("ela_present", float, None, "Today's ELA (m): the ELA at 0 ka.", parser=Number("m"),
        panel=CHRONOLOGY_PANEL),
    Opt("ela_glacial", float, None, "The ELA at the last glacial maximum (m; the chronology's most glacial "
        "value between 14 and 30 ka).", parser=Number("m"), panel=CHRONOLOGY_PANEL),
    Opt("ela_lapse_rate", float, None, "With --ela-kind temperature: metres the ELA rises per kelvin of "
        "warming (1/0.0065 ≈ 154 m/K).", parser=Number("m/K", 0.0, above=True), panel=CHRONOLOGY_PANEL),
    Opt("from_ka", float, None, "Age (ka) where a chronology-driven run starts.", flags=("--from",),
        parser=Number("ka", 0.0), panel=CHRONOLOGY_PANEL),
    Opt("to_ka", float, 0.0, "Age (ka) where it ends (0 = today).", flags=("--to",), parser=Number("ka", 0.0),
        panel=CHRONOLOGY_PANEL),
)
DIAGNOSTIC = (
    Opt("ice_thickness", Path, None, "Ice thickness (m) on the DEM's grid: the initial ice, or with "
        "--diagnostic the geometry to solve.", role="input"),
    Opt("diagnostic", bool, False, "Solve the velocity of DEM + --ice-thickness once (no time stepping, "
        "relative residual 1e-5) and write --velocity and --sliding.", kind="flag"),
)
SIDE_OUTPUTS = (
    Opt("ice", Path, None, "Write the final ice thickness (m).", role="output", panel=SIDE_OUTPUT_PANEL,
        record=False),
    Opt("velocity", Path, None, "Write the surface velocity (GeoTIFF, 2 bands: vx east, vy along the rows = "
        "south; m/y) of the final geometry.", role="output", panel=SIDE_OUTPUT_PANEL, record=False),
    Opt("sliding", Path, None, "Write the basal sliding speed (m/y) of the final geometry.", role="output",
        panel=SIDE_OUTPUT_PANEL, record=False),
    Opt("lakes", Path, None, "Write the lake depth (m) of the final bed: depressions not filled by ice, to "
        "their spill level; count, area and volume in its sidecar.", role="output", panel=SIDE_OUTPUT_PANEL,
        record=False),
    Opt("timeline", Path, None, "Write a CSV with one row per step: time, age, ELA, ice volume and area, "
        "eroded volumes, lake area.", role="output", panel=SIDE_OUTPUT_PANEL, record=False),
    Opt("snapshot_every", float, None, "Write the ice thickness every this many years: ICE_001.tif, ... "
        "after --ice (else OUT_ice_001.tif, ...).", parser=POSITIVE_YEARS, panel=SIDE_OUTPUT_PANEL),
    SNAPSHOTS_NC,
)

OPTIONS = (
    SOURCE, OUTPUT, ELA, DURATION, DT, *ICE_FLOW, *TRANSPORT, *ICE_FREE_GROUND, *ELA_CHRONOLOGY,
    *DIAGNOSTIC, *SIDE_OUTPUTS, *READING, FORCE, *RASTER_OUTPUT,
    with_default(CHECKPOINTS[0], 100), *CHECKPOINTS[1:],
) + parameter_options(PARAMETER_PANELS)


@declared("glaciate", OPTIONS)
class GlacierRun:
    """One run of the glacier model, as ``OPTIONS`` declare it (lengths in m, times in years,
    ages in ka, the background slope in degrees; parameter values as given, a number or a
    raster path)."""

    @property
    def replaces(self) -> bool:
        """Whether existing outputs may be replaced: --overwrite, or --resume (the outputs of the
        run being continued)."""
        return self.overwrite or self.resume

    @property
    def given_parameters(self) -> dict[str, str]:
        """The glacier model's parameter values given (name → text)."""
        values = {name: getattr(self, name) for name in self.PARAMETERS}
        return {name: text for name, text in values.items() if text is not None}
