"""Default stage dynamics: a stack-actuated flexure stage as a second-order system.

``STAGE`` maps the actuator's displacement (µm, the output of the hysteresis
model) to the stage's displacement (µm)::

    G(s) = w1^2 / (s^2 + 2 zeta w1 s + w1^2),   w1 = 2 pi 600 Hz,  zeta = 0.1

Why these numbers
-----------------
The paper's rig (Gu, Zhu, Su 2014, Sec. IV) is a PSt 150/7/100 VS12 stack
(0-150 V, about 100 µm stroke, so a ceramic column of roughly 100 mm with a
7 mm diameter) driving a double-parallelogram flexure-hinge stage of nominal
75 µm travel.  The paper gives no stage dynamics, so the numbers are
representative, not identified:

* Static gain 1 (µm of stage per µm of actuator).  The hysteresis model is
  identified on the loaded actuator, so it already contains the stroke lost to
  the flexure's stiffness (100 µm → 75 µm says the flexure is about a third as
  stiff as the stack).
* First resonance 600 Hz.  A stack of this size has an axial stiffness of the
  order of 10 N/µm; with the flexure in parallel and a moving mass (platform,
  part of the flexure and of the stack, sensor and fixture) of a few hundred
  grams to about 0.7 kg, the first mode lies between roughly 600 Hz and 1 kHz.
  We take the low end, a loaded stage.
* Damping ratio 0.1: a lightly damped mode (resonance peak 1/(2 zeta
  sqrt(1 - zeta^2)) ≈ 5, +14 dB).  Bare metal flexures are lighter still (0.01
  to 0.05); the stack's internal losses and its preload add some damping.

With zeta = 0.1 the -3 dB point of G lies at 1.543 w1, about 926 Hz: a perfect
rate-independent compensator in front of this stage would show about the
paper's compensated 884 Hz.

What is left out
----------------
The amplifier is taken as an ideal voltage source: a real one driving the
stack's capacitance of several µF is current limited, so its large-signal
bandwidth falls with amplitude.  The stack's own modes (several kHz), the
sensor and its conditioner, and creep are not modelled either.  All of them are
rate dependent, i.e. outside the rate-independent hysteresis model.
"""
import math

import control

RESONANCE_HZ = 600.0
DAMPING_RATIO = 0.1
STATIC_GAIN = 1.0

_W1 = 2.0 * math.pi * RESONANCE_HZ

STAGE = control.tf([STATIC_GAIN * _W1**2], [1.0, 2.0 * DAMPING_RATIO * _W1, _W1**2],
                   inputs="actuator_um", outputs="stage_um", name="flexure_stage")
