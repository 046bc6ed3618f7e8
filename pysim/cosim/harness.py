"""Co-simulation harness: reference → [inverse FMU] → plant FMU → stage.

The FMUs are FMI 2.0 co-simulation units with direct feed-through: at each
communication point the harness sets the input, reads the output (computed
from the input and the committed operator memory) and then calls
``fmi2DoStep``, which commits the memory.  fmpy reads the model description,
extracts, instantiates and initialises the FMUs; the hot loop then calls the
shared library's ``fmi2SetReal``/``fmi2GetReal``/``fmi2DoStep`` directly
through ctypes with prebuilt argument buffers, so a step costs little more
than the three C calls.  The inverse's output buffer is handed straight to the
plant's ``fmi2SetReal``: the voltage never becomes a Python object on its way.

The chain is open loop, so the stage (any python-control LTI system, see
:mod:`pysim.cosim.stage`) is applied to the whole plant-output record of a run in
one vectorised call, with its state carried from run to run.
"""
from __future__ import annotations

import ctypes
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pysim.cosim.errors import CoSimulationError
from pysim.cosim.stage import DiscreteStage

PLANT_PORTS = ("voltage", "displacement")            # input V, output µm
INVERSE_PORTS = ("displacement_ref", "voltage")      # input µm, output V

_STATUS = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal", 5: "Pending"}


@dataclass
class CoSimResult:
    """Samples at the communication points of one run.

    Attributes
    ----------
    time_s : ndarray
        Communication points, s.
    reference_um : ndarray or None
        Desired displacement fed to the inverse FMU (None for a voltage-driven run).
    voltage_V : ndarray
        Voltage at the plant's input.
    displacement_plant_um : ndarray
        Actuator displacement, the plant FMU's output.
    displacement_stage_um : ndarray
        Stage displacement (equals the plant's output when there is no stage).
    """

    time_s: np.ndarray
    reference_um: np.ndarray | None
    voltage_V: np.ndarray
    displacement_plant_um: np.ndarray
    displacement_stage_um: np.ndarray


class FMUUnit:
    """One extracted, instantiated and initialised FMI 2.0 co-simulation FMU
    with one real input and one real output, and the raw calls for stepping it.

    Parameters
    ----------
    path : str or Path
        The ``.fmu`` file.
    ports : (str, str)
        Preferred names of the input and output variables; if the FMU has no
        variables of these names but exactly one real input and one real
        output, those are used.
    instance_name : str
        Name of the instance (shows in the FMU's log messages).
    parameters : dict, optional
        ``{name: value}`` of real parameters set at every initialisation
        (e.g. ``{"a2": 0.31, "b[3]": 0.02}``: another model in the same FMU,
        no rebuild).
    """

    def __init__(self, path, ports, instance_name, parameters=None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.path = Path(path)
        if self.path.is_dir():
            raise CoSimulationError(f"{self.path}: is a directory, not an FMU file")
        if not self.path.is_file():
            raise CoSimulationError(f"{self.path}: FMU file does not exist")
        try:
            md = read_model_description(str(self.path))
        except Exception as exc:  # fmpy raises plain exceptions for bad archives
            raise CoSimulationError(f"{self.path}: not a readable FMU ({exc})") from exc
        if md.fmiVersion != "2.0" or md.coSimulation is None:
            raise CoSimulationError(f"{self.path}: not an FMI 2.0 co-simulation FMU")
        self.model_description = md
        self.input, self.output = self._ports(md, ports)
        self.parameters = self._parameter_refs(md, parameters or {})
        self._unzipdir = extract(str(self.path))
        self._slave = None
        try:
            callbacks, self.instance_name, self.messages = _callbacks(instance_name)
            self._slave = FMU2Slave(guid=md.guid, unzipDirectory=self._unzipdir,
                                    modelIdentifier=md.coSimulation.modelIdentifier,
                                    instanceName=self.instance_name)
            self._slave.instantiate(callbacks=callbacks, loggingOn=False)
            self._initialise()
        except Exception as exc:
            self.close()
            # no binary for this platform, or a model that refuses its parameters
            raise CoSimulationError(f"{self.path}: cannot load and initialise the FMU ({exc})") from exc
        # Raw entry points for the hot loop.  Fresh function pointers (indexing,
        # not attribute access) so fmpy's own bindings keep their settings.  No
        # argtypes: every argument is passed as a ctypes object of the exact C
        # type, which ctypes hands over without the per-call from_param
        # conversion that argtypes costs (measured: about half the step time).
        dll = self._slave.dll
        self.set_real = dll["fmi2SetReal"]
        self.get_real = dll["fmi2GetReal"]
        self.do_step = dll["fmi2DoStep"]
        for fn in (self.set_real, self.get_real, self.do_step):
            fn.restype = ctypes.c_int  # fmi2Status
        self.component = ctypes.c_void_p(self._slave.component)
        self.input_vr = (ctypes.c_uint * 1)(self.input.valueReference)
        self.output_vr = (ctypes.c_uint * 1)(self.output.valueReference)

    @staticmethod
    def _ports(md, preferred):
        real = [v for v in md.modelVariables if v.type == "Real"]
        by_name = {v.name: v for v in real}
        inputs = [v for v in real if v.causality == "input"]
        outputs = [v for v in real if v.causality == "output"]
        chosen = []
        for name, causality, candidates in zip(preferred, ("input", "output"), (inputs, outputs)):
            var = by_name.get(name)
            if var is not None and var.causality == causality:
                chosen.append(var)
            elif len(candidates) == 1:
                chosen.append(candidates[0])
            else:
                raise CoSimulationError(f"{md.modelName}: no real {causality} named {name!r} "
                                f"(and not exactly one real {causality} to use instead)")
        return chosen

    def _parameter_refs(self, md, parameters):
        refs = {v.name: v.valueReference for v in md.modelVariables
                if v.causality == "parameter" and v.type == "Real"}
        unknown = sorted(set(parameters) - set(refs))
        if unknown:
            raise CoSimulationError(f"{self.path}: no real parameter named {', '.join(map(repr, unknown))}")
        return {refs[name]: float(value) for name, value in parameters.items()}

    def _initialise(self):
        self._slave.setupExperiment(startTime=0.0)
        self._slave.enterInitializationMode()
        if self.parameters:
            self._slave.setReal(list(self.parameters), list(self.parameters.values()))
        self._slave.exitInitializationMode()

    def reset(self):
        """Back to the state after initialisation (demagnetised), time 0."""
        self._slave.reset()
        self._initialise()

    def range(self):
        """(min, max) of the input: the variable's declared min/max, else the
        start values of parameters ``voltage_min``/``voltage_max`` (the plant
        FMUs of this project); None where neither is given."""
        starts = {v.name: v.start for v in self.model_description.modelVariables
                  if v.causality == "parameter" and v.type == "Real"}
        out = []
        for declared, parameter in ((self.input.min, "voltage_min"), (self.input.max, "voltage_max")):
            value = declared if declared is not None else starts.get(parameter)
            out.append(None if value is None else float(value))
        return tuple(out)

    def close(self):
        """Terminate and free the instance, unload the library, remove the files."""
        if self._slave is not None and self._slave.component is not None:
            try:
                self._slave.terminate()
            except Exception:
                pass  # freeing below is what matters
            self._slave.freeInstance()
            self._slave.component = None
        _LOG["messages"].pop(getattr(self, "instance_name", None), None)
        if self._unzipdir is not None:
            shutil.rmtree(self._unzipdir, ignore_errors=True)
            self._unzipdir = None


class CoSimulation:
    """Steps a plant FMU (and optionally an inverse FMU in front of it) and a
    linear stage behind it.

    Parameters
    ----------
    plant_fmu : str or Path
        Plant FMU: input ``voltage`` (V) → output ``displacement`` (µm).
    inverse_fmu : str or Path, optional
        Inverse FMU: input ``displacement_ref`` (µm) → output ``voltage`` (V).
    stage : control.TransferFunction or control.StateSpace, optional
        SISO stage, µm of actuator → µm of stage; None for none.
    step_s : float
        Communication step, s.
    stage_method : {"tustin", "zoh", "foh"}
        Discretisation of a continuous stage (see :mod:`pysim.cosim.stage`).
    prewarp_hz : float, optional
        Tustin prewarp frequency, Hz.
    stage_start : {"rest", "steady"}
        Stage state after a reset: at rest, or in equilibrium with the first
        plant output of the next run (no start-up step).

    Notes
    -----
    Use as a context manager (or call :meth:`close`) to free the FMUs.
    Successive :meth:`run` calls continue the same simulation.
    """

    def __init__(self, plant_fmu, inverse_fmu=None, stage=None, step_s: float = 1e-4,
                 stage_method: str = "tustin", prewarp_hz: float | None = None, stage_start: str = "rest"):
        if stage_start not in ("rest", "steady"):
            raise CoSimulationError(f"stage_start must be 'rest' or 'steady', got {stage_start!r}")
        self.stage_system = stage
        self.stage_method = stage_method
        self._make_stage = None if stage is None else DiscreteStage.factory(stage, stage_method)
        self.stage_start = stage_start
        self.stage = None
        self.step_s = None
        self.prewarp_hz = None
        self._configure(step_s, prewarp_hz)  # bad step or stage: refused before any FMU is loaded
        self._units = []
        self.plant = self._open(plant_fmu, PLANT_PORTS, "plant")
        self.inverse = None if inverse_fmu is None else self._open(inverse_fmu, INVERSE_PORTS, "inverse")
        self._steps = 0
        self._pending_steady = stage_start == "steady"

    def _open(self, path, ports, name):
        try:
            unit = FMUUnit(path, ports, name)
        except BaseException:
            self.close()
            raise
        self._units.append(unit)
        # the fallback to "the one real input" must not accept the other kind of FMU
        other, other_input = ("inverse", INVERSE_PORTS[0]) if name == "plant" else ("plant", PLANT_PORTS[0])
        if unit.input.name == other_input:
            self.close()
            raise CoSimulationError(f"{unit.path}: its input is {other_input!r}, so it is the {other} FMU, "
                            f"not the {name} FMU")
        return unit

    def _configure(self, step_s, prewarp_hz):
        if not (isinstance(step_s, (int, float)) and np.isfinite(step_s) and step_s > 0):
            raise CoSimulationError(f"step must be a positive number of seconds, got {step_s!r}")
        if self.stage_system is not None and (step_s != self.step_s or prewarp_hz != self.prewarp_hz):
            self.stage = self._make_stage(step_s, prewarp_hz)
        self.step_s, self.prewarp_hz = float(step_s), prewarp_hz

    # ---------------------------------------------------------------- control
    def reset(self, step_s: float | None = None, prewarp_hz: float | None = None):
        """Back to time 0: FMUs reset (operator memory demagnetised), stage
        state as chosen by ``stage_start``; optionally a new step/prewarp."""
        for unit in self._units:
            unit.reset()
        self._configure(self.step_s if step_s is None else step_s, prewarp_hz)
        if self.stage is not None:
            self.stage.reset()
        self._steps = 0
        self._pending_steady = self.stage_start == "steady"

    @property
    def time_s(self) -> float:
        """Time of the next communication point, s."""
        return self._steps * self.step_s

    def close(self):
        """Free the FMUs (idempotent)."""
        while getattr(self, "_units", None):
            self._units.pop().close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -------------------------------------------------------------------- run
    def run(self, reference_um=None, *, voltage_V=None) -> CoSimResult:
        """Advance by one communication step per input sample.

        Parameters
        ----------
        reference_um : array_like, optional
            Desired displacement, µm: needs the inverse FMU.
        voltage_V : array_like, optional
            Plant voltage, V: drives the plant directly (no inverse).

        Returns
        -------
        CoSimResult
        """
        if (reference_um is None) == (voltage_V is None):
            raise CoSimulationError("give exactly one of reference_um and voltage_V")
        if reference_um is not None and self.inverse is None:
            raise CoSimulationError("a reference needs an inverse FMU; drive the plant with voltage_V instead")
        signal = np.asarray(reference_um if voltage_V is None else voltage_V, dtype=float)
        if signal.ndim != 1:
            raise CoSimulationError(f"input must be one-dimensional, got shape {signal.shape}")
        if not np.all(np.isfinite(signal)):
            raise CoSimulationError("input contains NaN or infinite samples")
        n = signal.size
        times = (self._steps + np.arange(n)) * self.step_s
        if reference_um is not None:
            voltage, displacement = self._loop_chain(signal.tolist(), times.tolist())
            reference = signal.copy()
        else:
            voltage, displacement = signal.copy(), self._loop_plant(signal.tolist(), times.tolist())
            reference = None
        self._steps += n
        if self.stage is None:
            stage_out = displacement.copy()
        else:
            if self._pending_steady and n:
                self.stage.reset(float(displacement[0]))
            stage_out = self.stage.apply(displacement)
        if n:
            self._pending_steady = False
        return CoSimResult(times, reference, voltage, displacement, stage_out)

    # The loops below are the hot path: locals only, statuses OR-ed and checked
    # once per unit and step (Warning = 1 passes, anything worse stops).
    def _loop_plant(self, voltages, times):
        p = self.plant
        set_real, get_real, do_step = p.set_real, p.get_real, p.do_step
        comp, vr_in, vr_out = p.component, p.input_vr, p.output_vr
        u, y = (ctypes.c_double * 1)(), (ctypes.c_double * 1)()
        t, h, one, true = ctypes.c_double(), ctypes.c_double(self.step_s), ctypes.c_size_t(1), ctypes.c_int(1)
        out = [0.0] * len(voltages)
        for k, (tk, v) in enumerate(zip(times, voltages)):
            u[0] = v
            t.value = tk
            if (set_real(comp, vr_in, one, u) | get_real(comp, vr_out, one, y) | do_step(comp, t, h, true)) > 1:
                raise step_failure(p, u, y, tk, "voltage", v)
            out[k] = y[0]
        return np.array(out)

    def _loop_chain(self, references, times):
        q, p = self.inverse, self.plant
        q_set, q_get, q_step = q.set_real, q.get_real, q.do_step
        p_set, p_get, p_step = p.set_real, p.get_real, p.do_step
        qc, q_in, q_out = q.component, q.input_vr, q.output_vr
        pc, p_in, p_out = p.component, p.input_vr, p.output_vr
        r, v, y = (ctypes.c_double * 1)(), (ctypes.c_double * 1)(), (ctypes.c_double * 1)()
        t, h, one, true = ctypes.c_double(), ctypes.c_double(self.step_s), ctypes.c_size_t(1), ctypes.c_int(1)
        n = len(references)
        volts, out = [0.0] * n, [0.0] * n
        for k, (tk, x) in enumerate(zip(times, references)):
            r[0] = x
            t.value = tk
            if (q_set(qc, q_in, one, r) | q_get(qc, q_out, one, v) | q_step(qc, t, h, true)) > 1:
                raise step_failure(q, r, v, tk, "reference", x)
            if (p_set(pc, p_in, one, v) | p_get(pc, p_out, one, y) | p_step(pc, t, h, true)) > 1:
                raise step_failure(p, v, y, tk, "voltage", v[0])
            volts[k] = v[0]
            out[k] = y[0]
        return np.array(volts), np.array(out)


_LOG = {"callbacks": None, "messages": {}, "count": 0}


def _callbacks(role: str):
    """FMI callbacks whose logger writes to stderr (never stdout, which may
    carry JSON) and keeps each instance's last messages for error reports.

    fmpy's native proxy, which formats the variadic arguments, forwards to
    one Python logger per process, so one set of callbacks serves every
    instance and the messages are told apart by unique instance names.  With
    logging off the FMU only reports errors, so the hot loop never calls back.

    Returns (callbacks, instance_name, messages list of that instance).
    """
    from fmpy.fmi2 import (
        calloc,
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
        free,
    )

    if _LOG["callbacks"] is None:
        def log(_environment, instance, status, _category, message):
            name = instance.decode("utf-8", "replace") if instance else "?"
            text = message.decode("utf-8", "replace") if message else ""
            kept = _LOG["messages"].get(name)
            if kept is not None:
                kept.append(text)
                del kept[:-20]
            print(f"{name} FMU [{_STATUS.get(status, status)}] {text}", file=sys.stderr)

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(log)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            from fmpy.logging import addLoggerProxy

            addLoggerProxy(ctypes.byref(callbacks))
        except Exception:
            pass  # messages then arrive unformatted, which is still readable
        _LOG["callbacks"] = callbacks
    _LOG["count"] += 1
    name = role if _LOG["count"] == 1 else f"{role}-{_LOG['count']}"
    messages = _LOG["messages"].setdefault(name, [])
    return _LOG["callbacks"], name, messages


def step_failure(unit: FMUUnit, u, y, t: float, what: str, value: float) -> RuntimeError:
    """The error for a failed step.  fmi2SetReal and fmi2GetReal have no side
    effect worth protecting, so they are repeated to find which call failed;
    if both pass, it was fmi2DoStep (its status was OR-ed with theirs)."""
    where = f"{unit.path.name}: at t = {t:.9g} s ({what} = {value:.9g})"
    failed = "fmi2DoStep failed"
    for name, fn, vr, buf in (("fmi2SetReal", unit.set_real, unit.input_vr, u),
                              ("fmi2GetReal", unit.get_real, unit.output_vr, y)):
        status = fn(unit.component, vr, ctypes.c_size_t(1), buf)
        if status > 1:
            failed = f"{name} returned {_STATUS.get(status, status)}"
            break
    last = f": {unit.messages[-1]}" if unit.messages else ""
    return RuntimeError(f"{where}: {failed}{last}")


@dataclass(frozen=True)
class NominalDrive:
    """The uncompensated drive: a voltage proportional to the desired
    displacement, through the ends of the first loading curve,
    ``v = low_V + (x_d - low_um) / gain_um_per_V``.

    For a model starting at 0 V and 0 µm this is ``v = x_d / gain`` with the
    nominal gain :meth:`pysim.core.model.HysteresisModel.major_loop_gain`.
    """

    low_V: float
    low_um: float
    gain_um_per_V: float

    def __call__(self, reference_um) -> np.ndarray:
        return self.low_V + (np.asarray(reference_um, dtype=float) - self.low_um) / self.gain_um_per_V

    @classmethod
    def from_model(cls, model) -> "NominalDrive":
        """From a :class:`pysim.core.model.HysteresisModel`."""
        lo, _ = model.voltage_range_V
        return cls(lo, float(model.simulate([lo])[0]), model.major_loop_gain())

    @classmethod
    def from_plant(cls, sim: CoSimulation, voltage_range_V=None) -> "NominalDrive":
        """Measured through the plant FMU (same definition as the model's:
        first loading from the demagnetised state, range low to range high).
        The range defaults to the min/max the FMU declares for its input.
        Leaves the simulation reset."""
        lo, hi = sim.plant.range() if voltage_range_V is None else voltage_range_V
        if lo is None or hi is None:
            raise CoSimulationError(f"{sim.plant.path.name}: the voltage input declares no min/max; "
                            "give the model spec (or the voltage range) for the nominal gain")
        sim.reset()
        y = sim.run(voltage_V=[lo, hi]).displacement_plant_um
        sim.reset()
        return cls(float(lo), float(y[0]), float((y[1] - y[0]) / (hi - lo)))


def fmus_for_model(model, out_dir=None) -> tuple[Path, Path]:
    """Plant and inverse FMUs of ``model`` for this machine, built if needed.

    Parameters
    ----------
    model : HysteresisModel
    out_dir : str or Path, optional
        Where the FMUs go (default: a per-model folder in the package cache,
        ``$PIEZO_MPI_CACHE`` or ``~/.cache/piezo-mpi``); the builder's own
        cache makes a repeated call cheap.

    Returns
    -------
    (plant_path, inverse_path)
    """
    import hashlib

    from fmpy import platform

    from pysim.core.spec import spec_source
    from pysim.core.toolchain import cache_dir
    from pysim.fmu import build_fmus

    if out_dir is None:
        digest = hashlib.sha256(spec_source(model).encode()).hexdigest()[:12]
        out_dir = cache_dir() / "fmus" / f"{model.name}-{digest}"
    paths = build_fmus(model, Path(out_dir), platforms=(platform,))
    return Path(paths["plant"]), Path(paths["inverse"])


def plant_fmu_for_model(model, out_dir=None) -> Path:
    """The plant FMU of ``model`` for this machine, built if needed -- also
    for a model whose inverse does not exist (a rig's true actuator).

    Parameters
    ----------
    model : HysteresisModel or ExtendedModel
    out_dir : str or Path, optional
        As in :func:`fmus_for_model`.
    """
    import hashlib

    from fmpy import platform

    from pysim.core.spec import spec_source
    from pysim.core.toolchain import cache_dir
    from pysim.fmu import build_fmus

    if out_dir is None:
        digest = hashlib.sha256(spec_source(model).encode()).hexdigest()[:12]
        out_dir = cache_dir() / "fmus" / f"{model.name}-{digest}"
    return Path(build_fmus(model, Path(out_dir), platforms=(platform,), kinds=("plant",))["plant"])

