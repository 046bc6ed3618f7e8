"""What holds of the input say about a verdict: a rate-independent actuator stands still in them.

Inside a hold after a step (:func:`pysim.diagnosis.folds.hold_runs`) a
rate-independent actuator's output is constant, and so is any
rate-independent model's prediction, whatever its shape error.  Creep, a lag,
a delay, a slew limit or a disturbance keep the output moving there.  Two
rules follow:

* :func:`still_holds` -- when every record that holds its input long enough
  shows the plain fit's residual standing still in its holds, what no model
  explains is a hysteresis shape outside the model class, not an effect;
* :func:`contradicted_by_holds` -- in such holds, a cause whose model moves
  where the actuator stands still is contradicted by the record.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pysim.diagnosis.folds import hold_runs
from pysim.diagnosis.residuals import motion_within_holds
from pysim.diagnosis.rules import NOISE_FRACTION

__all__ = ["MIN_HOLDS", "MIN_HOLD_SAMPLES", "MIN_HOLD_DOF", "HeldRecord", "still_holds", "still_sentence",
           "contradicted_by_holds", "contradicted_sentence"]

#: A record whose holds can show an actuator rate independent: at least MIN_HOLDS holds after
#: steps of MIN_HOLD_SAMPLES samples or more, MIN_HOLD_DOF degrees of freedom in all (the noise of
#: the motion estimate is then below 0.07 σ², against a bar of NOISE_FRACTION).
MIN_HOLDS = 5
MIN_HOLD_SAMPLES = 10
MIN_HOLD_DOF = 400

#: Causes a hold cannot contradict: a slow trend moves a few hundredths of its amplitude within a
#: hold, below what the holds' noise lets the motion measure tell.
_NOT_SEEN_IN_HOLDS = ("drift",)


@dataclass
class HeldRecord:
    """A record whose holds vote: its position among the records given, name, hold ranges, and
    the plain fit's motion in them.

    ``excess_sigma2`` is :func:`pysim.diagnosis.residuals.motion_within_holds` of the plain
    fit's residual (σ² beyond the noise), over ``dof`` degrees of freedom.
    """

    index: int
    name: str
    runs: list
    dof: int
    excess_sigma2: float
    noise_um: float
    displacement_um: np.ndarray


def still_holds(records) -> list:
    """The records whose holds vote, when every one shows the residual standing still; else [].

    Parameters
    ----------
    records : iterable of (name, voltage_V, displacement_um, plain_prediction_um, noise_um)
        Each record and the plain (rate-independent) fit's prediction of it.  A record votes
        when it has ``MIN_HOLDS`` holds or more and ``MIN_HOLD_DOF`` degrees of freedom in them;
        the records with fewer do not (the slow turns of band-limited noise, held for a few
        samples within a percent of the range, are no test: a rate-independent output still
        follows the input there).

    Returns
    -------
    list of HeldRecord
        Empty when no record votes or any voter's residual moves by ``NOISE_FRACTION`` σ² or more.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> v = np.repeat(rng.uniform(0.0, 100.0, 12), 200)          # 12 steps, each held 200 samples
    >>> shape_error = 0.01 * (v - 50.0) ** 2 / 50.0              # rate independent: constant in a hold
    >>> y = v + shape_error + rng.normal(0.0, 0.05, v.size)
    >>> [(h.name, len(h.runs)) for h in still_holds([("staircase", v, y, v, 0.05)])]
    [('staircase', 11)]
    >>> lagging = np.convolve(v, np.full(20, 0.05))[:v.size]        # a 20-sample moving average
    >>> still_holds([("staircase", v, lagging + rng.normal(0.0, 0.05, v.size), v, 0.05)])
    []
    """
    found = []
    for index, (name, voltage, y, plain, noise_um) in enumerate(records):
        runs = hold_runs(voltage, MIN_HOLD_SAMPLES)
        if len(runs) >= MIN_HOLDS:
            y = np.asarray(y, dtype=float)
            excess, dof = motion_within_holds(y - np.asarray(plain, dtype=float), runs, noise_um)
            if dof >= MIN_HOLD_DOF and math.isfinite(excess):
                found.append(HeldRecord(index, name, runs, dof, excess, noise_um, y))
    if any(h.excess_sigma2 >= NOISE_FRACTION for h in found):
        return []
    return found


def still_sentence(held) -> str:
    """Why the residual standing still in ``held`` (:func:`still_holds`) names nothing."""
    where = " and ".join(f"the {len(h.runs)} holds of {h.name} ({h.excess_sigma2:+.2g} σ² beyond the noise over "
                         f"{h.dof} degrees of freedom)" for h in held)
    return (f"the residual does not move within {where}, where creep, a lag, a delay, a slew limit or a "
            "disturbance would move it: the actuator is rate independent there, and what the models leave is a "
            "hysteresis shape outside the model class, not an effect")


def contradicted_by_holds(held, causes, predictions) -> dict:
    """The causes whose models move in holds where the actuator stands still.

    Parameters
    ----------
    held : list of HeldRecord
        :func:`still_holds` of the records: the plain fit's residual stands still in them.
    causes : sequence of str
        The causes named.
    predictions : callable
        ``predictions(cause, index)``: that cause's model's prediction (µm) of the record at
        ``index`` among those given to :func:`still_holds`, or None when it has none there.

    Returns
    -------
    dict
        ``cause -> (record name, motion σ², plain fit's motion σ²)`` for every cause whose
        model's residual moves in the holds of a voting record by ``NOISE_FRACTION`` σ² or
        more beyond the plain fit's: the model draws creep, a lag or a delay there, and the
        record shows none.  Drift is never contradicted (too slow to move within a hold).

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> v = np.repeat(rng.uniform(0.0, 100.0, 12), 200)
    >>> y = v + rng.normal(0.0, 0.05, v.size)
    >>> held = still_holds([("staircase", v, y, v, 0.05)])
    >>> creeping = v + 0.3 * (1.0 - np.exp(-(np.arange(v.size) % 200) / 40.0))   # settles in every hold
    >>> models = {"creep": creeping, "delay": v}
    >>> sorted(contradicted_by_holds(held, ["creep", "delay"], lambda c, index: models[c]))
    ['creep']
    """
    out = {}
    for cause in causes:
        if cause in _NOT_SEEN_IN_HOLDS:
            continue
        for h in held:
            prediction = predictions(cause, h.index)
            if prediction is None or np.shape(prediction) != h.displacement_um.shape:
                continue
            excess, _ = motion_within_holds(h.displacement_um - np.asarray(prediction, dtype=float), h.runs,
                                            h.noise_um)
            if math.isfinite(excess) and excess >= h.excess_sigma2 + NOISE_FRACTION:
                out[cause] = (h.name, excess, h.excess_sigma2)
                break
    return out


def contradicted_sentence(contradicted: dict) -> str:
    """Why the causes of ``contradicted`` (:func:`contradicted_by_holds`) are ruled out."""
    return (" and ".join(f"{c}'s model moves within the holds of {name} ({excess:+.2g} σ² beyond the noise, "
                         f"the plain fit's residual {plain:+.2g} σ²)"
                         for c, (name, excess, plain) in contradicted.items())
            + ", where the actuator stands still: "
            + ("it draws" if len(contradicted) == 1 else "they draw")
            + " dynamics the record does not show")
