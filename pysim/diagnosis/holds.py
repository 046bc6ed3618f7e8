"""What holds of the input say about a verdict: a rate-independent actuator stands still in them.

Inside a hold after a step (:func:`pysim.diagnosis.folds.hold_runs`) a
rate-independent actuator's output is constant, and so is any
rate-independent model's prediction, whatever its shape error.  Creep, a lag,
a delay, a slew limit or a disturbance keep the output moving there.  Three
rules follow:

* :func:`still_holds` -- when every record that holds its input long enough
  shows the plain fit's residual standing still in its holds, what no model
  explains is a hysteresis shape outside the model class, not an effect;
* :func:`contradicted_by_holds` -- in such holds, a cause whose model moves
  where the actuator stands still is contradicted by the record;
* :func:`preferred_by_holds` -- where the holds move, the motion is the effect
  alone, free of the shape error: a cause whose model follows it far better
  than the named cause's joins the verdict (the named cause is kept, as its
  model may still carry the hysteresis to a new input better);
* :func:`named_by_moving_holds` -- where nothing else is named but the holds
  move beyond what their noise allows, the cause whose model takes up that
  motion is named: no rate-independent actuator can move there;
* :func:`staircase_holds` and :func:`without_hold_levels` -- on a record made
  mostly of holds, a model's level in each hold is where the rate-independent
  fits extrapolate (a held-out hold at a level its training blocks never
  reached), so a cause must also remove error with each hold's level taken out
  of every model's residual (:func:`pysim.diagnosis.rules.decide`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pysim.diagnosis.folds import hold_runs
from pysim.diagnosis.residuals import motion_within_holds
from pysim.diagnosis.rules import NEAR_NOISE_FRACTION, NEAR_NOISE_T, NOISE_FRACTION

__all__ = ["MIN_HOLDS", "MIN_HOLD_SAMPLES", "MIN_HOLD_DOF", "STAIRCASE_SHARE", "HeldRecord", "voting_holds",
           "still_holds", "staircase_holds", "without_hold_levels",
           "still_sentence", "contradicted_by_holds", "contradicted_sentence", "preferred_by_holds",
           "named_by_moving_holds", "moving_holds_sentence"]

#: A record whose holds can show an actuator rate independent: at least MIN_HOLDS holds after
#: steps of MIN_HOLD_SAMPLES samples or more, MIN_HOLD_DOF degrees of freedom in all (the noise of
#: the motion estimate is then below 0.07 σ², against a bar of NOISE_FRACTION).
MIN_HOLDS = 5
MIN_HOLD_SAMPLES = 10
MIN_HOLD_DOF = 400

#: A record is a staircase when its holds (MIN_HOLDS or more, each of MIN_HOLD_SAMPLES) hold at least
#: this share of the samples its cross-validation scores.
STAIRCASE_SHARE = 0.5

#: Causes a hold cannot contradict: a slow trend moves a few hundredths of its amplitude within a
#: hold, below what the holds' noise lets the motion measure tell.
_NOT_SEEN_IN_HOLDS = ("drift",)


@dataclass
class HeldRecord:
    """A record whose holds vote: its position among the records given, name, hold ranges, and
    the plain fit's motion in them.

    ``excess_sigma2`` is :func:`pysim.diagnosis.residuals.motion_within_holds` of the plain
    fit's residual (σ² beyond the noise), over ``dof`` degrees of freedom; ``plain_um`` is the
    plain fit's prediction of the record.
    """

    index: int
    name: str
    runs: list
    dof: int
    excess_sigma2: float
    noise_um: float
    displacement_um: np.ndarray
    plain_um: np.ndarray = None


def voting_holds(records) -> list:
    """The records whose holds vote, with the plain fit's motion in them.

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

    Examples
    --------
    >>> v = np.repeat([0.0, 80.0, 20.0, 100.0, 50.0, 10.0], 200)
    >>> [(h.name, len(h.runs), h.dof) for h in voting_holds([("staircase", v, v, v, 0.05), ("ramp", v[:4], v[:4], v[:4], 0.05)])]
    [('staircase', 5, 995)]
    """
    found = []
    for index, (name, voltage, y, plain, noise_um) in enumerate(records):
        runs = hold_runs(voltage, MIN_HOLD_SAMPLES)
        if len(runs) >= MIN_HOLDS:
            y = np.asarray(y, dtype=float)
            excess, dof = motion_within_holds(y - np.asarray(plain, dtype=float), runs, noise_um)
            if dof >= MIN_HOLD_DOF and math.isfinite(excess):
                found.append(HeldRecord(index, name, runs, dof, excess, noise_um, y, np.asarray(plain, dtype=float)))
    return found


def staircase_holds(voltage_V, scored_mask) -> list | None:
    """The holds of a record that is a staircase, else None.

    Parameters
    ----------
    voltage_V : array_like
    scored_mask : array_like of bool
        The samples the blocked cross-validation scores (:func:`pysim.diagnosis.folds.record_folds`).

    Returns
    -------
    list of (first, stop) or None
        :func:`pysim.diagnosis.folds.hold_runs` of ``MIN_HOLD_SAMPLES`` samples or more, when
        there are ``MIN_HOLDS`` of them and they hold ``STAIRCASE_SHARE`` of the scored samples.

    Examples
    --------
    >>> v = np.repeat([0.0, 80.0, 20.0, 100.0, 50.0, 10.0], 200)
    >>> scored = np.arange(v.size) >= 200
    >>> staircase_holds(v, scored)
    [(200, 400), (400, 600), (600, 800), (800, 1000), (1000, 1200)]
    >>> staircase_holds(np.sin(np.arange(1200) / 40.0), scored) is None
    True
    """
    v = np.asarray(voltage_V, dtype=float)
    runs = hold_runs(v, MIN_HOLD_SAMPLES)
    if len(runs) < MIN_HOLDS:
        return None
    scored = np.asarray(scored_mask, dtype=bool)
    held = np.zeros(v.size, dtype=bool)
    for first, stop in runs:
        held[first:stop] = True
    n_scored = int(scored.sum())
    return runs if n_scored and (held & scored).sum() >= STAIRCASE_SHARE * n_scored else None


def without_hold_levels(y, prediction_um, runs, folds) -> np.ndarray:
    """``prediction_um`` moved so that its residual has mean zero in every hold, block by block.

    A rate-independent model is constant in a hold, and its error there is the level it reaches:
    on a held-out block of a staircase that level is extrapolated from the other blocks' levels
    (weights of operators a block alone moves are free elsewhere).  Taking each hold's mean out
    of the residual -- separately for each held-out block a hold reaches into, whose predictions
    come from different fits -- leaves what an effect draws there: the ramp of a slew limit, the
    settling of a lag or a delay after the step, creep within the hold, and everything outside
    the holds.  Drift keeps only the part of its trend that moves within a hold.

    Parameters
    ----------
    y, prediction_um : array_like
        Measured and predicted displacement (µm); the prediction may be NaN where it does not predict.
    runs : list of (first, stop)
        The holds (:func:`staircase_holds`).
    folds : list of (train, scored)

    Returns
    -------
    numpy.ndarray
        The moved prediction (µm).

    Examples
    --------
    >>> y = np.repeat([1.0, 5.0, 2.0], 100)
    >>> y[100:103] = [2.0, 3.0, 4.0]                            # a ramp after the second step
    >>> p = np.repeat([1.5, 4.0, 2.0], 100)                     # levels off in two holds
    >>> folds = [(None, np.arange(0, 150)), (None, np.arange(150, 300))]
    >>> r = y - without_hold_levels(y, p, [(0, 100), (100, 200), (200, 300)], folds)
    >>> float(np.abs(r[:100]).max()), float(np.abs(r[150:]).max()), np.round(r[100:104], 2)
    (0.0, 0.0, array([-2.88, -1.88, -0.88,  0.12]))
    """
    y = np.asarray(y, dtype=float)
    residual = y - np.asarray(prediction_um, dtype=float)
    block = np.full(y.size, -1)
    for index, (_, scored) in enumerate(folds):
        block[scored] = index
    for first, stop in runs:
        for index in set(block[first:stop].tolist()) - {-1}:
            where = first + np.flatnonzero(block[first:stop] == index)
            finite = where[np.isfinite(residual[where])]
            if finite.size:
                residual[where] -= residual[finite].mean()
    return y - residual


def still_holds(voters) -> list:
    """The voting records ``voters`` (:func:`voting_holds`), when every one shows the residual
    standing still; else [].

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
    >>> [(h.name, len(h.runs)) for h in still_holds(voting_holds([("staircase", v, y, v, 0.05)]))]
    [('staircase', 11)]
    >>> lagging = np.convolve(v, np.full(20, 0.05))[:v.size]        # a 20-sample moving average
    >>> still_holds(voting_holds([("staircase", v, lagging + rng.normal(0.0, 0.05, v.size), v, 0.05)]))
    []
    """
    if any(h.excess_sigma2 >= NOISE_FRACTION for h in voters):
        return []
    return list(voters)


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
        ``index`` among those given to :func:`voting_holds`, or None when it has none there.

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
    >>> held = still_holds(voting_holds([("staircase", v, y, v, 0.05)]))
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


def _motion(held, prediction) -> float:
    """The motion (σ², dof-weighted over the records ``held``) that ``prediction(index)`` leaves in
    their holds; NaN when a record has no such prediction."""
    total, dof = 0.0, 0
    for h in held:
        p = prediction(h.index)
        if p is None or np.shape(p) != h.displacement_um.shape:
            return float("nan")
        excess, n = motion_within_holds(h.displacement_um - np.asarray(p, dtype=float), h.runs, h.noise_um)
        if not math.isfinite(excess):
            return float("nan")
        total, dof = total + excess * n, dof + n
    return total / dof if dof else float("nan")


def preferred_by_holds(held, named: str, others, predictions):
    """The causes whose models follow the motion in the holds far better than ``named``'s, or None.

    Inside a hold the hysteresis part of every model is constant, so whatever the record does
    there is the effect alone, free of the shape error that the rest of the record mixes in.
    Where the holds move (the plain fit's residual by ``NOISE_FRACTION`` σ² or more on a voting
    record), a cause whose model leaves at most half the motion that ``named``'s model leaves,
    and ``NOISE_FRACTION`` σ² less than both it and the plain fit, is preferred: the one that
    leaves the least, with every other within ``NOISE_FRACTION`` σ² of it (the holds do not tell
    those apart).  The holds see the effect only, not how a model carries the hysteresis to a
    new input, so the caller adds these causes to the verdict and keeps ``named`` in it.

    Parameters
    ----------
    held : list of HeldRecord
        :func:`voting_holds` of the records.
    named : str
        The cause named so far.
    others : sequence of str
        The other causes to weigh.
    predictions : callable
        ``predictions(cause, index)`` as for :func:`contradicted_by_holds`.

    Returns
    -------
    None or (causes, motions)
        ``causes``: a tuple, the least motion first; ``motions``: cause (and ``"plain"``) -> the
        motion its model leaves in the moving holds (σ²).

    Examples
    --------
    >>> rng = np.random.default_rng(3)
    >>> v = np.repeat(rng.uniform(0.0, 100.0, 12), 300)
    >>> lag = np.convolve(v - v[0], 1 / 30 * np.exp(-np.arange(300) / 30.0))[:v.size] + v[0]
    >>> y = lag + rng.normal(0.0, 0.05, v.size)
    >>> held = voting_holds([("staircase", v, y, v, 0.05)])
    >>> slow = v + 0.5 * (lag - v)                 # a model that draws half of the settling
    >>> found = preferred_by_holds(held, "creep", ["rate_dependence"], lambda c, i: {"creep": slow, "rate_dependence": lag}[c])
    >>> found[0], found[1]["rate_dependence"] < 0.1 < found[1]["creep"]
    (('rate_dependence',), True)
    """
    moving = [h for h in held if h.excess_sigma2 >= NOISE_FRACTION]
    if not moving:
        return None
    plain = sum(h.excess_sigma2 * h.dof for h in moving) / sum(h.dof for h in moving)
    motions = {"plain": plain, named: _motion(moving, lambda i: predictions(named, i))}
    for cause in others:
        if cause != named:
            motions[cause] = _motion(moving, lambda i, c=cause: predictions(c, i))
    if not math.isfinite(motions[named]):
        return None
    better = [c for c, m in motions.items()
              if c not in ("plain", named) and math.isfinite(m) and m <= 0.5 * motions[named]
              and m + NOISE_FRACTION <= min(motions[named], plain)]
    if not better:
        return None
    # causes whose models follow the holds within NOISE_FRACTION σ² of the best one are not told
    # apart by them (independent seed 153: a lag and an input low-pass leave 0.047 and 0.030 σ²)
    least = min(motions[c] for c in better)
    return tuple(sorted((c for c in better if motions[c] <= least + NOISE_FRACTION), key=motions.get)), motions


def _motion_across_holds(held) -> tuple:
    """``(excess σ², t)``: the plain fit's motion pooled over every hold of the records ``held``
    (as :func:`pysim.diagnosis.residuals.motion_within_holds`, weighted by each hold's degrees of
    freedom), and that mean over its standard error taken from the spread between the holds, which
    noise correlated from sample to sample widens as it widens the motion of each hold."""
    excess, weight = [], []
    for h in held:
        residual = h.displacement_um - h.plain_um
        for first, stop in h.runs:
            e, n = motion_within_holds(residual[first:stop], [(0, stop - first)], h.noise_um)
            if n > 0 and math.isfinite(e):
                excess.append(e)
                weight.append(n)
    if len(excess) < MIN_HOLDS:
        return float("nan"), float("nan")
    e, w = np.asarray(excess), np.asarray(weight, dtype=float)
    mean = float(np.sum(w * e) / np.sum(w))
    error = float(np.sqrt(np.sum((w * (e - mean)) ** 2)) / np.sum(w))
    return mean, (mean / error if error > 0 else float("inf"))


def named_by_moving_holds(held, causes, predictions):
    """The causes named by holds that move where nothing else names one, or None.

    Inside a hold after a step every rate-independent actuator stands still, whatever its loop
    shape, and so does every rate-independent model's prediction.  When the plain fit's residual
    moves in the holds by ``NEAR_NOISE_FRACTION`` σ² or more, and by ``NEAR_NOISE_T`` standard
    errors taken from the spread between the holds, the actuator is not rate independent: a cause
    whose model leaves at most half of that motion is named, with every other whose model leaves
    within a quarter of the motion of the one that leaves least (the holds do not tell those
    apart).  Creep of a few tenths of a second that a staircase holds 0.23 s at a time moves
    0.16 σ² there, over 15 500 degrees of freedom: below what the blocked cross-validation names
    (the fits absorb most of it between the holds), and eight standard errors above no motion.

    Parameters
    ----------
    held : list of HeldRecord
        :func:`voting_holds` of the records.
    causes : sequence of str
        The causes to weigh (the caller leaves out those its other rules rule out).
    predictions : callable
        ``predictions(cause, index)`` as for :func:`contradicted_by_holds`.

    Returns
    -------
    None or (causes, motions, t)
        ``causes``: a tuple, the least motion first; ``motions``: cause (and ``"plain"``) -> the
        motion its model leaves in the holds (σ²); ``t``: the plain fit's motion in standard errors.

    Examples
    --------
    >>> rng = np.random.default_rng(5)
    >>> v = np.repeat(rng.uniform(0.0, 100.0, 30), 400)              # 30 steps, each held 400 samples
    >>> step_response = 0.02 * (1 - np.exp(-np.arange(v.size) / 100.0))   # creep: 2 % of a step, τ = 100 samples
    >>> creep = np.convolve(np.diff(v, prepend=v[0]), step_response)[:v.size]
    >>> y = v + creep + rng.normal(0.0, 0.1, v.size)
    >>> held = voting_holds([("staircase", v, y, v, 0.1)])
    >>> models = {"creep": v + creep, "delay": v}
    >>> found = named_by_moving_holds(held, ["creep", "delay"], lambda c, i: models[c])
    >>> found[0], found[1]["creep"] < 0.1 < found[1]["plain"], found[2] > 3
    (('creep',), True, True)
    >>> still = voting_holds([("staircase", v, v + 0.001 * v**2 + rng.normal(0.0, 0.1, v.size), v, 0.1)])
    >>> named_by_moving_holds(still, ["creep", "delay"], lambda c, i: models[c]) is None
    True
    """
    if not held:
        return None
    plain, t = _motion_across_holds(held)
    if not (plain >= NEAR_NOISE_FRACTION and t >= NEAR_NOISE_T):
        return None
    motions = {"plain": plain}
    for cause in causes:
        motions[cause] = _motion(held, lambda i, c=cause: predictions(c, i))
    follow = [c for c in causes if math.isfinite(motions[c]) and motions[c] <= 0.5 * plain]
    if not follow:
        return None
    least = min(motions[c] for c in follow)
    tied = [c for c in follow if motions[c] <= least + 0.25 * (plain - least)]
    return tuple(sorted(tied, key=motions.get)), motions, t


def moving_holds_sentence(held, found) -> str:
    """Why the causes of ``found`` (:func:`named_by_moving_holds`) are named."""
    causes, motions, t = found
    where = " and ".join(f"the {len(h.runs)} holds of {h.name}" for h in held)
    return (f"the plain fit's residual moves within {where} by {motions['plain']:.2g} σ² beyond the noise "
            f"({t:.2g} standard errors from the spread between the holds), where a rate-independent actuator "
            f"stands still whatever its loop shape; "
            + ", ".join(f"{c}'s model leaves {motions[c]:+.2g} σ²" for c in causes)
            + " of that motion")
