"""A rig in co-simulation: the compensator against an actuator it does not
mirror, with amplifier, converters, sensor noise and feedback.

:class:`Rig` describes a nanopositioning rig part by part (a composition: the
actuator's plant model, then amplifier, stage, sensor, converters and
controller; each part's discrete behaviour is defined in
:mod:`pysim.core.rig`).  :class:`RigSimulation` runs it at a fixed
communication step ``h`` (the controller's sample period) with the plant as an
FMU and, for compensation, the inverse FMU of *another* model -- typically one
identified from data recorded on the rig -- so what the co-simulation predicts
is what mismatch, converters, amplifier limits and noise leave.

Co-simulation semantics
-----------------------
The rig is a chain of units connected at the communication points, exactly as
a fixed-step co-simulation master runs connected FMUs (the scheme of fmpy's
SSP simulation, so an SSP of the rig's FMUs gives the same samples):

- at every step each unit reads its inputs -- the values its sources had at
  the end of the *previous* step (all values start at 0, the rig at rest at
  0 V) -- advances over ``[t, t + h)`` with them held, and exposes its outputs
  at ``t + h``;
- then the connections carry the new outputs to the inputs.

So no unit sees a value computed in the same step: no algebraic loop, one pass
per step, and each connection is a sample-and-hold.  The units and what they
compute in a step (``[.]`` = input held over the step):

=============  ==========================================  =======================
unit           output at ``t + h``                         inputs from
=============  ==========================================  =======================
inverse        ``P^-1[r_ahead]`` (V), the inverse FMU      reference ahead
controller     ``DAC(u / gain)``, ``u = PI(r - m, ff)``    reference, sensor, feedforward
amplifier      ``a`` after one step of :class:`Amplifier`  controller
actuator       ``H[v]`` (µm), the plant FMU                amplifier
stage          ZOH state-space step of the stage (µm)      actuator
sensor         ``ADC(s + noise)`` (µm)                     stage
=============  ==========================================  =======================

The feedforward ``ff`` is ``ff_scale * input + ff_offset``: the inverse's
voltage (scale 1, offset 0) on the compensated paths; the reference itself
through the nominal drive (scale 1/gain, offset of the first loading curve) on
the uncompensated path.  Because every connection holds for a step, the
feedforward is fed the reference ``preview`` steps ahead (the DSP generates the
reference, so it knows it): 6 steps with the inverse unit in front, 5 without,
which lines the stage's output up with the reference.  The feedback sees the
real latency of the loop.

Paths (configurations) a rig can run:

``"uncompensated"``        open loop, nominal drive ``v = x_d / gain``
``"compensated"``          open loop, the inverse FMU as feedforward
``"feedback"``             the PI controller alone
``"feedback+compensated"`` the PI controller with the inverse FMU as feedforward
"""
from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field

import numpy as np

from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise
from pysim.cosim.errors import CoSimulationError
from pysim.cosim.harness import INVERSE_PORTS, PLANT_PORTS, CoSimResult, FMUUnit, NominalDrive, step_failure
from pysim.cosim.stage import as_siso, discretise

PATHS = ("uncompensated", "compensated", "feedback", "feedback+compensated")
FEEDBACK_PATHS = ("feedback", "feedback+compensated")
# steps from the feedforward's input to the stage's output (see the module notes)
PREVIEW_STEPS = {"with_inverse": 6, "without_inverse": 5}
MAX_PREVIEW = max(PREVIEW_STEPS.values())

__all__ = ["Rig", "RigSimulation", "RigResult", "PATHS", "linear_loop"]


@dataclass(frozen=True)
class Rig:
    """A nanopositioning rig, part by part.

    Parameters
    ----------
    plant : HysteresisModel or ExtendedModel
        The actuator as it *is* (the truth of the simulation), V -> µm.
    stage : control.TransferFunction or control.StateSpace, optional
        Stage dynamics, µm of actuator -> µm of stage (None: none).
    amplifier : Amplifier
        Command (V) -> actuator voltage (V).
    dac : Converter
        The controller's output converter, V (0-10 V on the paper's rig).
    adc : Converter
        The sensor's converter, in µm of stage displacement.
    noise : SensorNoise
        Measurement noise.
    controller : PIController
        The feedback controller (used by the feedback paths).
    step_s : float
        The controller's sample period, s.
    name, description : str
        Identifier and where the numbers come from.
    """

    plant: object
    stage: object = None
    amplifier: Amplifier = field(default_factory=Amplifier)
    dac: Converter = field(default_factory=Converter)
    adc: Converter = field(default_factory=lambda: Converter(16, -10.0, 110.0))
    noise: SensorNoise = field(default_factory=SensorNoise)
    controller: PIController = field(default_factory=PIController)
    step_s: float = 1e-4
    name: str = "rig"
    description: str = ""

    def __post_init__(self):
        if not (isinstance(self.step_s, (int, float)) and math.isfinite(self.step_s) and self.step_s > 0):
            raise CoSimulationError(f"rig step_s must be a positive number of seconds, got {self.step_s!r}")
        for name, kind in (("amplifier", Amplifier), ("dac", Converter), ("adc", Converter),
                           ("noise", SensorNoise), ("controller", PIController)):
            if not isinstance(getattr(self, name), kind):
                raise CoSimulationError(f"rig {name} must be a {kind.__name__}, got "
                                        f"{type(getattr(self, name)).__name__}")
        if self.stage is not None:
            as_siso(self.stage)
        plant_T = getattr(getattr(self.plant, "stages", None), "sample_period_s", 0.0)
        if getattr(getattr(self.plant, "stages", None), "present", False) and not math.isclose(
                plant_T, self.step_s, rel_tol=1e-9):
            raise CoSimulationError(f"the plant's output stages run at {plant_T} s but the rig samples at "
                                    f"{self.step_s} s: identify the plant at the rig's rate")

    def with_parts(self, **changes) -> "Rig":
        """A copy with some parts replaced (``plant=``, ``amplifier=``, ...)."""
        from dataclasses import replace

        return replace(self, **changes)

    @property
    def voltage_range_V(self) -> tuple:
        return self.amplifier.output_low_V, self.amplifier.output_high_V


@dataclass
class RigResult(CoSimResult):
    """A :class:`pysim.cosim.harness.CoSimResult` with what the rig adds.

    Attributes
    ----------
    command_V : ndarray
        DAC output held over each sample, V.
    measured_um : ndarray
        The sensor's reading after the ADC, µm.
    path : str
        The configuration that ran.
    """

    command_V: np.ndarray = None
    measured_um: np.ndarray = None
    path: str = ""


class _Stage:
    """The stage as a state-space recursion on Python floats (exact ZOH at T)."""

    def __init__(self, system, step_s):
        if system is None:
            self.A = self.B = self.C = []
            self.D = 1.0
        else:
            import control

            d = control.ss(discretise(system, step_s, method="zoh"))      # a discrete tf as state space
            self.A = np.asarray(d.A, dtype=float).tolist()
            self.B = np.asarray(d.B, dtype=float).ravel().tolist()
            self.C = np.asarray(d.C, dtype=float).ravel().tolist()
            self.D = float(np.asarray(d.D, dtype=float).ravel()[0])
        self.z = [0.0] * len(self.B)

    def rest_at(self, x):
        """State of the input ``x`` held since forever."""
        n = len(self.B)
        if not n:
            return
        A = np.array(self.A)
        B = np.array(self.B)
        self.z = np.linalg.solve(np.eye(n) - A, B * x).tolist()


class RigSimulation:
    """Runs a :class:`Rig` with its plant FMU and, for compensation, an inverse FMU.

    Parameters
    ----------
    rig : Rig
    plant_fmu : path
        The FMU of ``rig.plant`` (built with :func:`pysim.cosim.harness.fmus_for_model`,
        which also builds plants whose inverse does not exist).
    inverse_fmu : path, optional
        The compensator: the inverse FMU of the model the controller believes in.
    drive : NominalDrive, optional
        The uncompensated drive (default: from the compensator's model if given
        via :meth:`from_models`, else measured through the plant FMU).
    plant_parameters, inverse_parameters : dict, optional
        FMU parameters set at initialisation (``{"a2": ..., "b[1]": ...}``):
        other models in the same FMUs, e.g. for Monte-Carlo runs.

    Notes
    -----
    Use as a context manager (or call :meth:`close`).  Every :meth:`run` starts
    from the rig at rest: the actuator demagnetised at the voltage of the first
    command, the stage at equilibrium, the controller's integrator empty.
    """

    def __init__(self, rig: Rig, plant_fmu, inverse_fmu=None, drive: NominalDrive | None = None,
                 plant_parameters=None, inverse_parameters=None):
        if not isinstance(rig, Rig):
            raise CoSimulationError(f"rig must be a Rig, got {type(rig).__name__}")
        self.rig = rig
        self.step_s = float(rig.step_s)
        self.stage_system = rig.stage
        self._units = []
        try:
            self.plant = self._open(plant_fmu, PLANT_PORTS, "plant", plant_parameters)
            self.inverse = None if inverse_fmu is None else self._open(inverse_fmu, INVERSE_PORTS, "inverse",
                                                                       inverse_parameters)
            self.drive = drive if drive is not None else NominalDrive.from_plant(self)
        except BaseException:
            self.close()
            raise

    @classmethod
    def from_models(cls, rig: Rig, compensator_model=None, fmu_dir=None) -> "RigSimulation":
        """Build (or reuse from the cache) the plant FMU of ``rig.plant`` and the
        inverse FMU of ``compensator_model`` (the hysteresis part is inverted;
        None: open loop without inverse), then open the simulation."""
        from pysim.cosim.harness import fmus_for_model, plant_fmu_for_model

        plant = plant_fmu_for_model(rig.plant, fmu_dir)
        inverse = None
        drive = None
        if compensator_model is not None:
            _, inverse = fmus_for_model(compensator_model, fmu_dir)
            drive = NominalDrive.from_model(getattr(compensator_model, "hysteresis", compensator_model))
        return cls(rig, plant, inverse, drive)

    def _open(self, path, ports, name, parameters=None):
        unit = FMUUnit(path, ports, name, parameters)
        self._units.append(unit)
        return unit

    # used by NominalDrive.from_plant: a voltage-driven run of the bare plant
    def reset(self, step_s=None, prewarp_hz=None):
        for unit in self._units:
            unit.reset()

    def run(self, reference_um=None, *, voltage_V=None):
        """The bare plant FMU driven by ``voltage_V`` (no rig parts): for the
        nominal drive.  Rig runs use :meth:`run_path`."""
        if voltage_V is None:
            raise CoSimulationError("RigSimulation.run drives the bare plant; use run_path for the rig")
        v = np.asarray(voltage_V, dtype=float)
        y = self._plant_outputs(v)
        t = np.arange(v.size) * self.step_s
        return CoSimResult(t, None, v, y, y.copy())

    def _plant_outputs(self, voltages):
        p = self.plant
        u, y = (ctypes.c_double * 1)(), (ctypes.c_double * 1)()
        t, h, one, true = ctypes.c_double(), ctypes.c_double(self.step_s), ctypes.c_size_t(1), ctypes.c_int(1)
        out = np.empty(len(voltages))
        for k, v in enumerate(voltages):
            u[0] = v
            t.value = k * self.step_s
            if (p.set_real(p.component, p.input_vr, one, u) | p.get_real(p.component, p.output_vr, one, y)
                    | p.do_step(p.component, t, h, true)) > 1:
                raise step_failure(p, u, y, t.value, "voltage", v)
            out[k] = y[0]
        return out

    def close(self):
        while self._units:
            self._units.pop().close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---------------------------------------------------------------- rig
    def run_path(self, reference_um, path: str) -> RigResult:
        """One run of the rig in configuration ``path`` (see the module notes)
        for the reference ``reference_um`` (µm, one sample per step), from
        rest at 0 V."""
        if path not in PATHS:
            raise CoSimulationError(f"path must be one of {PATHS}, got {path!r}")
        compensated = path in ("compensated", "feedback+compensated")
        feedback = path.startswith("feedback")
        if compensated and self.inverse is None:
            raise CoSimulationError(f"the {path} path needs an inverse FMU")
        if feedback and not self.rig.controller.active:
            raise CoSimulationError(f"the {path} path needs a controller with kp or ki > 0")
        r = np.asarray(reference_um, dtype=float)
        if r.ndim != 1 or r.size == 0 or not np.all(np.isfinite(r)):
            raise CoSimulationError("the reference must be a non-empty one-dimensional finite array")
        # the last `preview` samples see the final reference held: give the
        # reference that many samples past the part you evaluate
        self.reset()
        preview = PREVIEW_STEPS["with_inverse" if compensated else "without_inverse"]
        ahead = np.concatenate([r[preview:], np.full(min(preview, r.size), r[-1])])
        if compensated:
            scale, offset = 1.0, 0.0
        elif feedback:
            scale, offset = 0.0, 0.0
        else:
            scale = 1.0 / self.drive.gain_um_per_V
            offset = self.drive.low_V - self.drive.low_um / self.drive.gain_um_per_V
        return self._loop(r, ahead, compensated, feedback, scale, offset, path)

    def run_voltage(self, voltage_V) -> RigResult:
        """Drive the rig open loop with actuator voltages (V): the controller
        commands ``voltage / gain`` through the DAC, ahead by the preview, so
        the amplifier delivers the voltage at the matching sample.  Used to
        record identification data the way a rig records them."""
        v = np.asarray(voltage_V, dtype=float)
        if v.ndim != 1 or v.size == 0 or not np.all(np.isfinite(v)):
            raise CoSimulationError("the voltage must be a non-empty one-dimensional finite array")
        self.reset()
        preview = PREVIEW_STEPS["without_inverse"] - 2       # the voltage, not the stage, is lined up
        ahead = np.concatenate([v[preview:], np.full(min(preview, v.size), v[-1])])
        return self._loop(np.zeros(v.size), ahead, False, False, 1.0, 0.0, "voltage")

    def _loop(self, r, ahead, compensated, feedback, ff_scale, ff_offset, path):
        rig, T = self.rig, self.step_s
        amp, dac, adc, pi = rig.amplifier, rig.dac, rig.adc, rig.controller
        alpha, max_change = amp.coefficients(T)
        gain = amp.gain_V_per_V
        lo, hi = pi.output_low_V, pi.output_high_V
        noise_rms = rig.noise.rms_um
        noise = rig.noise.generator()
        stage = _Stage(rig.stage, T)
        A, B, C, D = stage.A, stage.B, stage.C, stage.D
        rows = range(len(B))
        z = [0.0] * len(B)
        one, true = ctypes.c_size_t(1), ctypes.c_int(1)
        t, h = ctypes.c_double(), ctypes.c_double(T)
        p, q = self.plant, self.inverse
        p_set, p_get, p_step, pc, p_in, p_out = (p.set_real, p.get_real, p.do_step, p.component, p.input_vr,
                                                 p.output_vr)
        if q is not None:
            q_set, q_get, q_step, qc, q_in, q_out = (q.set_real, q.get_real, q.do_step, q.component,
                                                     q.input_vr, q.output_vr)
        p_u, p_y, q_u, q_y = ((ctypes.c_double * 1)() for _ in range(4))
        # connector values: what each unit exposed at the end of the previous step
        c_ref = c_ahead = c_ff = c_cmd = c_amp = c_act = c_stage = c_meas = 0.0
        a = amp.initial_state(0.0)          # amplifier at rest at 0 V
        integrator = 0.0
        n = r.size
        out = {key: np.empty(n) for key in ("command", "voltage", "actuator", "stage", "measured")}
        reference, preview = r.tolist(), ahead.tolist()
        for k in range(n):
            t.value = k * T
            # inverse: its output for the held reference ahead
            if compensated:
                q_u[0] = c_ahead
                if (q_set(qc, q_in, one, q_u) | q_step(qc, t, h, true) | q_get(qc, q_out, one, q_y)) > 1:
                    raise step_failure(q, q_u, q_y, t.value, "reference", c_ahead)
                ff_next = q_y[0]
            else:
                ff_next = 0.0
            # controller: the command it exposes at t + h
            f = ff_scale * (c_ff if compensated else c_ahead) + ff_offset
            if feedback:
                u, integrator = pi.step(integrator, c_ref - c_meas, f, T)
            else:
                u = min(max(f, lo), hi)
            cmd_next = dac.convert(u / gain)
            # amplifier over the step with the held command
            a = amp._step(a, c_cmd, alpha, max_change)
            # actuator (plant FMU) for the held voltage
            p_u[0] = c_amp
            # read after the step: the output at t + h (for an actuator with output stages the
            # next sample; for the hysteresis alone the same value as before the step)
            if (p_set(pc, p_in, one, p_u) | p_step(pc, t, h, true) | p_get(pc, p_out, one, p_y)) > 1:
                raise step_failure(p, p_u, p_y, t.value, "voltage", c_amp)
            act_next = p_y[0]
            # stage: ZOH step with the held actuator displacement
            if rows:
                z = [_dot_left_to_right(A[i], z) + B[i] * c_act for i in rows]
                stage_next = D * c_act
                for i in rows:
                    stage_next += C[i] * z[i]
            else:
                stage_next = D * c_act
            # sensor for the held stage displacement
            meas_next = adc.convert(c_stage + noise_rms * noise.next()) if noise_rms else adc.convert(c_stage)
            # connections
            c_ref, c_ahead = reference[k], preview[k]
            c_ff, c_cmd, c_amp, c_act, c_stage, c_meas = ff_next, cmd_next, a, act_next, stage_next, meas_next
            out["command"][k], out["voltage"][k], out["actuator"][k] = c_cmd, c_amp, c_act
            out["stage"][k], out["measured"][k] = c_stage, c_meas
        # row k holds the values at t_{k+1}: the reference is compared at the same instants
        time = (np.arange(n) + 1) * T
        reference_at = np.concatenate([r[1:], r[-1:]])
        return RigResult(time, reference_at, out["voltage"], out["actuator"], out["stage"],
                         command_V=out["command"], measured_um=out["measured"], path=path)


def _dot_left_to_right(row, z) -> float:
    """``Σ row[j] z[j]`` added strictly left to right, as the stage FMU adds it
    (``sum`` of floats compensates its rounding from Python 3.12 on)."""
    total = 0.0
    for a, x in zip(row, z):
        total = total + a * x
    return total


def linear_loop(rig: Rig, plant_gain_um_per_V: float):
    """The rig's feedback loop as a python-control discrete system, for a
    linear actuator of gain ``plant_gain_um_per_V`` with ideal converters and an
    amplifier without bandwidth or slew limit: reference (µm) -> stage (µm),
    feedback alone.

    The forward path is ``F = K(z) g G(z) z^-3``: the PI controller
    ``K = kp + ki T / (z - 1)``, the actuator gain ``g``, the stage
    discretised with ZOH, and one step of hold in each of the controller,
    amplifier and actuator units; the sensor's step of hold is in the feedback
    path, so the loop gain is ``F z^-1`` and the closed loop ``F / (1 + F z^-1)``
    (see the module notes).  The reference reaches the controller one step
    late as well, which the closed loop returned here does not include.

    Examples
    --------
    >>> import control
    >>> from pysim.core import HysteresisModel
    >>> from pysim.core.rig import PIController
    >>> rig = Rig(HysteresisModel(0.0, 0.5, (0.0,), (0.0,)), controller=PIController(0.5, 500.0))
    >>> loop = linear_loop(rig, 0.5)
    >>> round(float(control.dcgain(loop)), 12)
    1.0
    """
    import control

    T = rig.step_s
    z = control.tf([1.0, 0.0], [1.0], T)
    pi = rig.controller
    controller = pi.kp_V_per_um + pi.ki_V_per_um_s * T / (z - 1)
    stage = control.tf([1.0], [1.0], T) if rig.stage is None else control.tf(discretise(rig.stage, T, "zoh"))
    forward = controller / (z * z * z) * plant_gain_um_per_V * stage
    return control.feedback(forward, 1 / z)


def sweep_frequencies(step_s: float, f_min_hz: float = 10.0, f_max_hz: float = 2000.0, points: int = 40):
    """Log-spaced frequencies rounded to a whole number of steps per period
    (the rig samples at a fixed rate), duplicates removed.

    Returns ``(frequencies_hz, samples_per_period)``.

    Examples
    --------
    >>> f, n = sweep_frequencies(5e-5, 10.0, 2000.0, 40)
    >>> bool(np.allclose(f * n * 5e-5, 1.0)), int(n[0]), int(n[-1])
    (True, 2000, 10)
    """
    if not (0 < f_min_hz < f_max_hz) or points < 2:
        raise CoSimulationError(f"need 0 < f_min < f_max and at least 2 points, got {f_min_hz}, {f_max_hz}, {points}")
    n = np.unique(np.round(1.0 / (np.geomspace(f_min_hz, f_max_hz, int(points)) * step_s)).astype(int))[::-1]
    n = n[n >= 4]
    if n.size < 2:
        raise CoSimulationError(f"the step {step_s} s leaves fewer than two sweep frequencies below {f_max_hz} Hz")
    return 1.0 / (n * step_s), n


def settling_time_s(sim: RigSimulation, path: str) -> float:
    """Time for the rig's slowest linear transient to fall by e^-1: the stage
    (and, on feedback paths, the closed loop linearised at the compensator's
    nominal gain), s."""
    import control

    from pysim.cosim.stage import slowest_time_constant_s

    tau = 0.0 if sim.rig.stage is None else slowest_time_constant_s(sim.rig.stage)
    if path in FEEDBACK_PATHS:
        loop = linear_loop(sim.rig, sim.drive.gain_um_per_V)
        radius = float(np.max(np.abs(control.poles(loop)))) if control.poles(loop).size else 0.0
        if radius >= 1.0:
            raise CoSimulationError(f"the feedback loop is unstable at the nominal gain (pole radius {radius:.4f}): "
                                    "lower kp or ki")
        if radius > 0:
            tau = max(tau, -sim.step_s / math.log(radius))
    return tau


def rig_stepped_sine(sim: RigSimulation, amplitude_um: float, offset_um: float, path: str,
                     frequencies_hz=None, settle_tol: float = 1e-4, measure_periods: int = 2, progress=None):
    """Stepped-sine response of one path of a rig at its fixed sample rate.

    At each frequency (whole steps per period, :func:`sweep_frequencies`) the
    rig runs from rest for one period plus enough periods for the slowest
    linear transient (:func:`settling_time_s`) to fall by ``settle_tol``, then
    the fundamental of the stage's displacement is taken over
    ``measure_periods`` whole periods and divided by the reference's (at the
    same instants): gain and phase against the desired sine.

    Returns
    -------
    pysim.cosim.bandwidth.SweepResult
        ``response`` against the desired sine; ``actuator_gain`` the
        actuator's fundamental over ``A``; ``settings`` also hold the
        ``error_rms_pct`` of the stage against the reference per frequency.
    """
    from pysim.cosim.bandwidth import SweepResult, fundamental

    if frequencies_hz is None:
        f, n_per = sweep_frequencies(sim.step_s)
    else:
        f = np.asarray(frequencies_hz, dtype=float)
        n_per = np.round(1.0 / (f * sim.step_s)).astype(int)
        if np.any(n_per < 4) or not np.allclose(n_per * f * sim.step_s, 1.0, rtol=1e-9):
            raise CoSimulationError("each frequency must have a whole number (>= 4) of steps per period; "
                                    "use sweep_frequencies")
    if not amplitude_um > 0:
        raise CoSimulationError(f"amplitude must be positive, got {amplitude_um} µm")
    tau = settling_time_s(sim, path)
    amp = sim.rig.amplifier
    if not math.isinf(amp.bandwidth_hz):
        tau = max(tau, 1.0 / (2.0 * math.pi * amp.bandwidth_hz))
    # the rig starts at rest at 0 V: the amplifier first slews to the offset
    startup_s = (abs(offset_um) + amplitude_um) / abs(sim.drive.gain_um_per_V) / amp.slew_rate_V_per_s
    response = np.empty(f.size, dtype=complex)
    actuator = np.empty(f.size)
    error_rms = np.empty(f.size)
    for i, (fi, n) in enumerate(zip(f, n_per)):
        settle = 1 + math.ceil(startup_s * fi) + (math.ceil(math.log(1.0 / settle_tol) * tau * fi) if tau > 0 else 0)
        # the reference runs on past the measurement by the feedforward's preview
        k = np.arange((settle + measure_periods) * int(n) + 1 + MAX_PREVIEW)
        reference = offset_um + amplitude_um * np.sin(2.0 * math.pi * k / n)
        result = sim.run_path(reference, path)
        tail = slice(settle * int(n), (settle + measure_periods) * int(n))
        wanted = fundamental(result.reference_um[tail], int(n))
        response[i] = fundamental(result.displacement_stage_um[tail], int(n)) / wanted
        actuator[i] = abs(fundamental(result.displacement_plant_um[tail], int(n))) / amplitude_um
        error = result.displacement_stage_um[tail] - result.reference_um[tail]
        error_rms[i] = 100.0 * math.sqrt(float(np.mean(error ** 2))) / (2.0 * amplitude_um)
        if progress is not None:
            progress.update()
    settings = {"samples_per_period": n_per.tolist(), "settle_tol": settle_tol,
                "measure_periods": measure_periods, "settling_time_s": tau, "error_rms_pct": error_rms.tolist(),
                "step_s": sim.step_s}
    return SweepResult(path, float(amplitude_um), float(offset_um), f, response, actuator, settings)


def tracking_bandwidth_hz(result, error_pct: float = 10.0) -> float:
    """Error-based tracking bandwidth: the first frequency where the RMS
    tracking error of the sine exceeds ``error_pct`` % of its peak-to-peak
    range, interpolated in log-frequency (NaN if never)."""
    f = np.asarray(result.frequencies_hz, dtype=float)
    e = np.asarray(result.settings["error_rms_pct"], dtype=float)
    above = np.flatnonzero(e > error_pct)
    if above.size == 0:
        return math.nan
    i = above[0]
    if i == 0:
        return float(f[0])
    x0, x1 = math.log(f[i - 1]), math.log(f[i])
    return math.exp(x0 + (error_pct - e[i - 1]) * (x1 - x0) / (e[i] - e[i - 1]))


def load_rig(source) -> Rig:
    """The ``RIG`` of a rig spec: a ``.py`` file, a module name, or a bare name
    of a shipped spec (``rig_default``); a :class:`Rig` is returned as is."""
    from pysim.core.errors import SpecError
    from pysim.core.spec import load_module

    if isinstance(source, Rig):
        return source
    try:
        module = load_module(source, "rig")
    except SpecError as exc:
        raise CoSimulationError(str(exc)) from exc
    rig = getattr(module, "RIG", None)
    if not isinstance(rig, Rig):
        raise CoSimulationError(f"{source}: defines no RIG of type pysim.cosim.rig.Rig")
    return rig
