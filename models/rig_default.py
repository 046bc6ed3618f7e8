"""Default rig: a PSt 150/7/100-class stack on a flexure stage, driven by a
current-limited amplifier from a 20 kHz real-time controller with 16-bit
converters -- the kind of rig the paper's experiments ran on (Sec. IV), with
representative numbers where the paper gives none.

``RIG`` is a :class:`pysim.cosim.rig.Rig`; ``pysim demo`` identifies a
compensator on it and co-simulates the compensator against it.

The parts, and why these numbers
--------------------------------
Actuator (``TRUTH``, what the rig *is*; never shown to the compensator):
    The paper's simulation example (``default_mpi``) as a *continuous*
    threshold density -- 40 operators at thresholds off the eq. 13 grid (the
    midpoints of 40 cells) -- with 8 % more hysteresis weight than the
    example, followed by creep: two slow modes of the input (time constants
    0.05 s and 1 s, together 3 % of the actuator's gain, a log-like step
    response).  A 10-operator model identified from rig data cannot reproduce
    it exactly: that, with noise and quantisation, is the mismatch a rig has.
Amplifier:
    Gain 15 V/V (0-10 V command to 0-150 V, as on the paper's rig),
    small-signal bandwidth 10 kHz, peak current 0.3 A into the stack's
    capacitance of 3.6 µF (a 150 V stack of 7 mm diameter and 100 mm length
    holds a few µF): slew rate ``I_max / C`` = 83 V/ms, so a 60 V-amplitude
    sine (30 µm) is slew limited above about 220 Hz, a 15 V one above about
    880 Hz -- the amplitude-dependent roll-off of a current-limited drive.
Stage:
    ``flexure_stage.STAGE``: 600 Hz, damping ratio 0.1 (see that spec).
Converters and sensor:
    16-bit DAC over 0-10 V and 16-bit ADC over -10..110 µm (the sensor's
    conditioner maps its range onto the ADC), as on a dSPACE DS1103;
    strain-gauge sensor noise 10 nm RMS.
Controller:
    20 kHz sampling (50 µs).  PI gains chosen for the lightly damped stage and
    the loop's five samples of latency (controller, amplifier, actuator, stage,
    sensor each hold a sample): integral gain 600 V/(µm·s) (crossover about
    45 Hz at the actuator's 0.5 µm/V) and proportional gain 0.05 V/µm keep the
    loop gain at the 600 Hz resonance below -8 dB (stable with margin, checked
    by the tests through :func:`pysim.cosim.rig.linear_loop`).
"""
import numpy as np

from pysim.core.extended import ExtendedModel, StageSpec
from pysim.core.model import HysteresisModel
from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise
from pysim.cosim.rig import Rig
from pysim.specs import default_mpi
from pysim.specs.flexure_stage import STAGE

STEP_S = 5e-5
N_TRUE_OPERATORS = 40
EXTRA_HYSTERESIS = 1.08
CREEP_TIME_CONSTANTS_S = (0.05, 1.0)
CREEP_SHARE = (0.012, 0.018)          # of the actuator's nominal gain, per mode


def _truth() -> ExtendedModel:
    span_V, scale_um = default_mpi.VOLTAGE_SPAN_V, default_mpi.DISPLACEMENT_SCALE_UM
    cells = np.arange(N_TRUE_OPERATORS)
    r_n = (cells + 0.5) / N_TRUE_OPERATORS                       # midpoints: off the eq. 13 grid
    b_n = EXTRA_HYSTERESIS * 5.0 * np.exp(-0.505 * (r_n - 1.0) ** 2) / N_TRUE_OPERATORS
    hysteresis = HysteresisModel(
        a1=default_mpi.A1_NORMALISED * scale_um / span_V ** 3,
        a2=default_mpi.A2_NORMALISED * scale_um / span_V,
        thresholds_V=tuple(r_n * span_V),
        weights_um_per_V=tuple(b_n * scale_um / span_V),
        voltage_range_V=(0.0, span_V),
        name="rig_actuator",
        description="the default rig's actuator: continuous threshold density, more hysteresis, creep")
    gain = hysteresis.major_loop_gain()
    stages = StageSpec(sample_period_s=STEP_S, creep_time_constants_s=CREEP_TIME_CONSTANTS_S,
                       creep_weights_um_per_V=tuple(share * gain for share in CREEP_SHARE))
    return ExtendedModel(hysteresis, stages)


TRUTH = _truth()

RIG = Rig(
    plant=TRUTH,
    stage=STAGE,
    amplifier=Amplifier(gain_V_per_V=15.0, bandwidth_hz=10e3, current_limit_A=0.3, capacitance_F=3.6e-6,
                        output_low_V=0.0, output_high_V=150.0),
    dac=Converter(16, 0.0, 10.0),
    adc=Converter(16, -10.0, 110.0),
    noise=SensorNoise(rms_um=0.01, seed=2014),
    controller=PIController(kp_V_per_um=0.05, ki_V_per_um_s=600.0, output_low_V=0.0, output_high_V=150.0),
    step_s=STEP_S,
    name="rig_default",
    description="PSt 150/7/100-class stack, flexure stage, current-limited amplifier, 20 kHz DSP, 16-bit I/O",
)
