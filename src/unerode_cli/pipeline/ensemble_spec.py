"""Ensemble specs: a pipeline spec (:mod:`unerode_cli.pipeline.spec`) plus a ``sweep:`` block,
turned into one resolved pipeline per member.

::

    version: 1
    vars: {data: ../shared/data}
    steps:
      - name: past
        run: climate-run
        args: [dem.tif, past.tif]
        options: {chronology: "${data}/lr04/LR04stack.txt", to: 20, snapshots: "10"}
    sweep:
      past.K: [1.0e-5, 2.0e-5]              # a list: every value (full grid)
      past.K-d: {uniform: [0.1, 3.0]}       # a distribution: sampled (Latin hypercube, --members)
      p: {log-uniform: [0.3, 1.0]}          # a bare option: every step that has it
      past.sea-level: [a.txt, b.txt]        # text values too (categorical)

A key is ``STEP.OPTION`` (one step's option, as in ``options:``) or a bare ``OPTION``, which
applies to every step whose subcommand has that option. A swept value replaces the step's own
value of that option; an integer option takes the nearest integer of a sampled number. The kinds
of entries and the sampling are described in :mod:`unerode_cli.ensemble.sweep`.

**Folders.** Each member runs in its own folder (``OUT_DIR/members/NNNN``), which replaces the
spec's ``workdir`` (it may be left out). Relative paths are relative to the spec's folder for
the files a step reads, and to the member's folder for those it writes; a step may not write
outside its member's folder, nor read outside the spec's folder, the ``--data`` folders and the
checkout's folders (:class:`~unerode_cli.pipeline.spec.Confinement`, as for a pipeline).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import Field

from unerode_cli.ensemble.sweep import Sweep, Value, parse_parameter
from unerode_cli.errors import InputError
from unerode_cli.pipeline.spec import (
    CommandSchema,
    Confinement,
    OutsideError,
    PipelineSpec,
    ResolvedPipeline,
    ResolvedStep,
    load_model,
    resolve,
)


class EnsembleSpec(PipelineSpec):
    """A pipeline spec with the parameters to sweep (key → list or distribution)."""

    sweep: dict[str, Any] = Field(min_length=1)


@dataclass(frozen=True)
class Target:
    """A step option that a sweep key sets (``option``: the option's long name)."""

    step: str
    option: str
    integer: bool


def load_ensemble_spec(path: Path) -> EnsembleSpec:
    """Read and check the structure of an ensemble spec (one-sentence InputError when wrong)."""
    return load_model(path, EnsembleSpec, "ensemble spec", "a YAML mapping with version, steps and sweep")


def parse_sweep(spec: EnsembleSpec) -> Sweep:
    """The sweep block as a :class:`Sweep` (InputError naming the key when malformed)."""
    parameters = []
    for key, raw in spec.sweep.items():
        try:
            parameters.append(parse_parameter(key, raw))
        except ValueError as exc:
            raise InputError(f"sweep '{key}': {str(exc).rstrip('.')}.") from None
    return Sweep(tuple(parameters))


def sweep_targets(spec: EnsembleSpec, schemas: Mapping[str, CommandSchema]) -> dict[str, list[Target]]:
    """The step options each sweep key sets; InputError for a key that names no step option
    that takes one value."""
    steps = {step.name: step for step in spec.steps}
    targets: dict[str, list[Target]] = {}
    for key in spec.sweep:
        step_name, _, option = key.rpartition(".")
        if step_name:
            if step_name not in steps:
                raise InputError(f"sweep '{key}': no step is named '{step_name}' "
                                 f"(steps: {', '.join(steps)}).")
            found = [_target(key, steps[step_name].name, steps[step_name].run, option, schemas, True)]
        else:
            found = [t for step in spec.steps
                     if (t := _target(key, step.name, step.run, option, schemas, False)) is not None]
            if not found:
                raise InputError(f"sweep '{key}': no step's subcommand has an option --{option}; "
                                 "name one step's option as STEP.OPTION.")
        targets[key] = [t for t in found if t is not None]
    return targets


def _target(key: str, step: str, command: str, option: str, schemas: Mapping[str, CommandSchema],
            required: bool) -> Target | None:
    schema = schemas.get(command)
    param = schema.option(option) if schema is not None else None
    if param is None or param.name in ("overwrite", "verbose", "quiet"):
        if required:
            raise InputError(f"sweep '{key}': {command} has no option --{option.lstrip('-')} "
                             f"that a sweep can set (step '{step}').")
        return None
    if param.kind not in ("value", "flag"):
        raise InputError(f"sweep '{key}': --{option} of {command} takes several values; "
                         "a sweep sets options of one value.")
    return Target(step, param.flags[0][2:], param.type == "int")


def member_spec(spec: EnsembleSpec, targets: Mapping[str, list[Target]],
                values: Mapping[str, Value], schemas: Mapping[str, CommandSchema]) -> PipelineSpec:
    """The pipeline of one member: the spec's steps with the swept options set to ``values``."""
    steps = []
    for step in spec.steps:
        options = dict(step.options)
        for key, value in values.items():
            for target in targets[key]:
                if target.step != step.name:
                    continue
                schema = schemas[step.run]
                same = [k for k in options if schema.option(k) == schema.option(target.option)]
                for k in same:
                    options.pop(k)
                integer = target.integer and isinstance(value, float) and not isinstance(value, bool)
                options[target.option] = round(value) if integer else value
        steps.append(step.model_copy(update={"options": options}))
    fields = spec.model_dump(exclude={"sweep", "steps", "workdir"})
    return PipelineSpec(**fields, steps=steps)


def member_pipeline(spec: PipelineSpec, spec_path: Path, schemas: Mapping[str, CommandSchema],
                    overrides: Mapping[str, str], folder: Path,
                    confinement: Confinement | None = None) -> ResolvedPipeline:
    """Resolve a member's pipeline to run in ``folder``: inputs read where the spec's folder
    places them, outputs written in ``folder``. InputError as ``pipeline run`` gives it
    (:class:`~unerode_cli.pipeline.spec.OutsideError` for a path out of ``confinement``)."""
    confinement = confinement or Confinement(writes_in="the member's folder")
    resolved = resolve(spec, spec_path, schemas, overrides, confinement)
    base = resolved.workdir
    written: dict[Path, Path] = {}
    for step in resolved.steps:
        for output in step.outputs:
            try:
                written[output] = folder / output.relative_to(base)
            except ValueError:
                raise OutsideError(f"step '{step.name}' (outputs): {output} lies outside the member's "
                                   "folder; members write relative paths only.") from None
    steps = [_moved(step, base, written) for step in resolved.steps]
    # members write in their folder only; --allow-outside paths stay readable
    member = dataclasses.replace(confinement, data=(*confinement.data, *confinement.allowed), allowed=())
    return ResolvedPipeline(resolved.spec_path, folder, steps, member)


def _moved(step: ResolvedStep, base: Path, written: Mapping[Path, Path]) -> ResolvedStep:
    """``step`` run from a member's folder: the files it reads but no step writes become
    absolute paths in its values and command line; what steps write moves into the folder."""
    read = {p for p in step.inputs if p not in written}
    argv = [_absolute_if_read(token, base, read) for token in step.argv]
    values = {name: [_absolute_if_read(v, base, read) if isinstance(v, str) else v for v in value]
              if isinstance(value, list) else
              _absolute_if_read(value, base, read) if isinstance(value, str) else value
              for name, value in step.values.items()}
    return dataclasses.replace(step, argv=argv, values=values,
                               inputs=[written.get(p, p) for p in step.inputs],
                               outputs=[written[p] for p in step.outputs])


def _absolute_if_read(token: str, base: Path, read: set[Path]) -> str:
    path = Path(token).expanduser()
    if path.is_absolute():
        return token
    located = (base / path).resolve()
    return str(located) if located in read else token
