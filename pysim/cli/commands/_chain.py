"""Options and set-up shared by ``pysim demo``, ``pysim track`` and ``pysim bandwidth``:
which model, stage and FMUs make up the co-simulated chain."""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from pysim.cli.errors import UserError

DEFAULT_MODEL = "default_mpi"
DEFAULT_STAGE = "flexure_stage"


def add_chain_arguments(parser) -> None:
    group = parser.add_argument_group("the co-simulated chain")
    group.add_argument("--model", metavar="SPEC",
                       help=f"model spec (file or name; default {DEFAULT_MODEL}); its FMUs are built if needed")
    group.add_argument("--stage", metavar="MODULE", default=DEFAULT_STAGE,
                       help=f"stage dynamics: a Python file or module defining STAGE (a python-control "
                            f"LTI system), or 'none' (default {DEFAULT_STAGE})")
    group.add_argument("--plant", metavar="FMU", help="plant FMU to use instead of building one")
    group.add_argument("--inverse", metavar="FMU", help="inverse FMU to use instead of building one")


@dataclass
class Chain:
    """The pieces of a co-simulation set up from the command line."""

    sim: object            # CoSimulation
    drive: object          # NominalDrive
    model: object          # HysteresisModel or None (FMUs given without a spec)
    stage: object          # LTI system or None
    plant_path: object
    inverse_path: object

    def close(self):
        self.sim.close()


def load_model(spec):
    from pysim.core.input_stage import InputStageModel
    from pysim.core.spec import load_spec

    model = load_spec(spec)     # a SpecError is reported by pysim.cli.main
    if isinstance(model, InputStageModel):
        raise UserError(f"{spec}: MODEL has an input stage before the hysteresis ({model.stage_summary()}), which "
                        "the co-simulated FMUs cannot hold; build the FMUs of the part after it with build-fmu "
                        "--without-input-stage and give them with --plant and --inverse")
    return model


def open_chain(args, step_s: float = 1e-4, sweep: bool = False) -> Chain:
    """Load the model and stage, find or build the FMUs, open the co-simulation.

    ``sweep``: the step will change per frequency, which a discrete stage
    cannot follow."""
    from pysim.cosim.harness import CoSimulation, NominalDrive, fmus_for_model
    from pysim.cosim.stage import load_stage

    if (args.plant is None) != (args.inverse is None):
        raise UserError("give both --plant and --inverse, or neither (to build them from the model)")
    stage = None if str(args.stage).lower() == "none" else load_stage(args.stage)
    if stage is not None and stage.dt:
        if sweep:
            raise UserError(f"{args.stage}: the stage is discrete, but a sweep changes the step with the "
                            "frequency: give the continuous stage")
        if stage.dt is True or not math.isclose(stage.dt, step_s, rel_tol=1e-9):
            raise UserError(f"{args.stage}: the discrete stage's dt ({stage.dt}) differs from the "
                            f"communication step ({step_s} s)")
    model = None
    if args.model is not None or args.plant is None:
        model = load_model(args.model or DEFAULT_MODEL)
    if args.plant is None:
        from pysim.fmu.build import check_model

        check_model(model, args.model or DEFAULT_MODEL)    # refused here, naming the spec, before any build
        print(f"FMUs of model {model.name}: building if not cached ...", file=sys.stderr, flush=True)
        plant, inverse = fmus_for_model(model)
    else:
        plant, inverse = args.plant, args.inverse
    sim = CoSimulation(plant, inverse, stage=stage, step_s=step_s)
    try:
        drive = NominalDrive.from_model(model) if model is not None else NominalDrive.from_plant(sim)
    except BaseException:
        sim.close()
        raise
    return Chain(sim, drive, model, stage, plant, inverse)
