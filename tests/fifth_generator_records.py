"""A fifth generator of measured-like piezo records, written by other hands without reading this package.

Written from the issue's description, the README and ``pysim diagnose --help`` only (no code of
``pysim``, of the tests or of the other generators was read), to find what the diagnosis and the
four generators before it share without saying so.  Its first run found a delay that a record
ending with a one-sample step hid (the fit through the delay refused the family) and spec files
that left out an input stage they were named for.

The plant is the MPI model with one-sided play operators, 8-40 thresholds not on a grid, weights
>= 0 of a decaying, bump-shaped or linear density, 0-100 V, 0-150 V or -20-120 V, 10-100 µm.
Sample rate 1, 2, 2.5, 5 or 10 kHz; white noise of 0.05-0.5 % of the displacement range, quantised
(12-16 bits) for about one actuator in three.  Three records per actuator (4000-30000 samples), each
of another input kind (:data:`INPUT_KINDS`: chirps, triangles of several amplitudes and
frequencies, multisines, steps with holds, band-limited noise, a sine on an offset, staircases;
not every input reaches both ends of the range); the first two start from rest or after an
unrecorded history, the third from rest.

One hidden effect per actuator, ``EFFECTS[seed % 7]``: none; a lag or a second-order stage after the
hysteresis; creep (2-4 slow modes of 2-40 % of the first record's length, driven by the input or
the hysteresis output); a delay of 1-5 whole samples; a drift (thermal, polynomial or a slow sine);
a first-order low-pass before the hysteresis; an amplifier slew limit.  Its strength is bisected so
that its RMS on the first record is 3-30 noise σ (for a delay the noise is moved instead, within
0.05-0.5 %).
"""
import numpy as np
from scipy import signal

EFFECTS = ["none", "rate_dependence", "creep", "delay", "drift",
           "rate_dependent_hysteresis", "slew_limit"]
INPUT_KINDS = ["chirp", "triangles", "multisine", "steps_holds", "bandlimited", "sine_offset",
               "staircase"]


def make_plant(rng):
    lo, hi = [(0.0, 100.0), (0.0, 150.0), (-20.0, 120.0)][rng.integers(3)]
    S = hi - lo
    n = int(rng.integers(8, 41))
    # thresholds: not on an even grid; the first one sometimes 0
    r = np.sort(rng.uniform(0.0, 0.92 * S, n))
    if rng.random() < 0.5:
        r[0] = 0.0
    # weights: a decaying or bump-shaped density times a random factor, all >= 0
    shape = rng.integers(3)
    x = r / S
    if shape == 0:
        dens = np.exp(-x / rng.uniform(0.15, 0.6))
    elif shape == 1:
        dens = np.exp(-((x - rng.uniform(0.0, 0.4)) / rng.uniform(0.15, 0.4)) ** 2)
    else:
        dens = 1.0 - 0.8 * x
    b = dens * rng.uniform(0.3, 1.7, n)
    b *= rng.uniform(0.3, 1.5) / b.sum()          # sum b relative to a2 = 1 (per volt)
    a2 = 1.0
    c = rng.uniform(-0.2, 0.25)                   # a1 = c a2 / S^2: loading curve stays monotone
    a1 = c * a2 / S ** 2
    # scale to a displacement range of 10..100 um on the first loading curve
    y_top = a1 * S ** 3 + a2 * S + np.sum(b * np.maximum(S - r, 0.0))
    target = rng.uniform(10.0, 100.0)
    g = target / y_top
    plant = dict(lo=lo, hi=hi, a1=a1 * g, a2=a2 * g, r=r.tolist(), b=(b * g).tolist(),
                 offset=float(rng.uniform(-5, 5)), disp_range=float(target))
    return plant


def hysteresis(plant, v, state=None):
    """MPI with one-sided play; state = operator outputs before the first sample (None: rest)."""
    r = np.asarray(plant["r"])
    b = np.asarray(plant["b"])
    u = np.asarray(v, float) - plant["lo"]
    w = np.zeros(len(r)) if state is None else np.array(state, float)
    out = np.empty(len(u))
    for k in range(len(u)):
        uk = u[k]
        w = np.maximum(uk - r, np.minimum(uk, w))
        out[k] = b @ w
    y = plant["a1"] * u ** 3 + plant["a2"] * u + out + plant["offset"]
    return y, w


# ----------------------------------------------------------------------------------------------
# inputs (normalised x in [0, 1]; v = lo + x S)
# ----------------------------------------------------------------------------------------------
def smooth_fade(n, m):
    f = np.ones(n)
    m = max(2, min(m, n))
    f[:m] = 0.5 - 0.5 * np.cos(np.pi * np.arange(m) / m)
    return f


def make_input(kind, rng, N, fs):
    D = N / fs
    t = np.arange(N) / fs
    fmin = max(3.0 / D, 0.3)
    fmax = min(fs / 40.0, 60.0)
    desc = {"kind": kind}
    if kind == "chirp":
        f0 = rng.uniform(fmin, 2 * fmin)
        f1 = rng.uniform(max(f0 * 3, 8.0), max(f0 * 4, fmax))
        c = rng.uniform(0.35, 0.65)
        a = rng.uniform(0.25, min(c, 1 - c))
        # log chirp
        k = np.log(f1 / f0) / D
        phase = 2 * np.pi * f0 * (np.exp(k * t) - 1) / k
        x = c - a * np.cos(phase)
        desc.update(f0=f0, f1=f1, center=c, amp=a)
    elif kind == "triangles":
        segs = []
        nn = 0
        amps, freqs = [], []
        while nn < N:
            a = rng.uniform(0.1, 1.0)
            base = rng.uniform(0, 1 - a) if rng.random() < 0.5 else 0.0
            f = rng.uniform(fmin, min(fmax, 15.0))
            per = max(int(fs / f), 8)
            ncyc = int(rng.integers(1, 4))
            half = per // 2
            tri = np.concatenate([np.linspace(0, 1, half, endpoint=False),
                                  np.linspace(1, 0, per - half, endpoint=False)])
            seg = base + a * np.tile(tri, ncyc)
            # connect from the previous value by a short ramp
            prev = segs[-1][-1] if segs else 0.0
            ramp = np.linspace(prev, base, max(int(0.02 * fs), 2), endpoint=False)
            segs += [ramp, seg]
            nn += len(ramp) + len(seg)
            amps.append(a); freqs.append(f)
        x = np.concatenate(segs)[:N]
        desc.update(amps=amps, freqs=freqs)
    elif kind == "multisine":
        m = int(rng.integers(3, 9))
        f = np.sort(rng.uniform(fmin, fmax, m))
        ph = rng.uniform(0, 2 * np.pi, m)
        amp = rng.uniform(0.3, 1.0, m) / np.sqrt(np.arange(1, m + 1))
        s = (amp[:, None] * np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None])).sum(0)
        lo_, hi_ = sorted(rng.uniform(0, 1, 2))
        if hi_ - lo_ < 0.4:
            lo_, hi_ = 0.05, 0.95
        x = lo_ + (hi_ - lo_) * (s - s.min()) / (s.max() - s.min())
        desc.update(freqs=f.tolist(), span=[lo_, hi_])
    elif kind == "steps_holds":
        x = np.empty(N)
        k = 0
        levels = []
        holds = []
        while k < N:
            h = int(rng.uniform(0.06, 0.2) * N)
            lev = rng.uniform(0, 1)
            x[k:k + h] = lev
            levels.append(lev); holds.append(h / fs)
            k += h
        desc.update(levels=levels, holds_s=holds)
    elif kind == "bandlimited":
        fc = rng.uniform(max(fmin * 3, 2.0), min(fmax, 30.0))
        bb, aa = signal.butter(3, fc / (fs / 2))
        s = signal.filtfilt(bb, aa, rng.standard_normal(N + 2000))[1000:1000 + N]
        lo_, hi_ = 0.0, 1.0
        if rng.random() < 0.4:
            lo_, hi_ = sorted(rng.uniform(0, 1, 2))
            hi_ = max(hi_, lo_ + 0.4); lo_ = min(lo_, hi_ - 0.4); lo_ = max(lo_, 0)
        x = lo_ + (hi_ - lo_) * (s - s.min()) / (s.max() - s.min())
        desc.update(cutoff_Hz=fc, span=[lo_, hi_])
    elif kind == "sine_offset":
        f = rng.uniform(fmin, min(fmax, 25.0))
        c = rng.uniform(0.3, 0.7)
        a = rng.uniform(0.15, min(c, 1 - c))
        x = c - a * np.cos(2 * np.pi * f * t)
        desc.update(freq=f, center=c, amp=a)
    elif kind == "staircase":
        nst = int(rng.integers(4, 12))
        hold = N // (2 * nst)
        up = np.linspace(0, 1, nst + 1)
        seq = np.concatenate([up, up[-2:0:-1]])
        x = np.repeat(seq, hold)
        x = np.concatenate([x, np.zeros(max(0, N - len(x)))])[:N]
        lo_, hi_ = (0.0, 1.0) if rng.random() < 0.6 else sorted(rng.uniform(0.0, 1.0, 2))
        if hi_ - lo_ < 0.4:
            lo_, hi_ = 0.0, 1.0
        x = lo_ + (hi_ - lo_) * x
        desc.update(steps=nst, hold_s=hold / fs, span=[lo_, hi_])
    else:
        raise ValueError(kind)
    return np.clip(x, 0.0, 1.0), desc


# ----------------------------------------------------------------------------------------------
# effects
# ----------------------------------------------------------------------------------------------
def lag1(x, tau, fs, x0=None):
    a = np.exp(-1.0 / (fs * tau))
    zi = [(x[0] if x0 is None else x0) * a]
    y, _ = signal.lfilter([1 - a], [1, -a], x, zi=zi)
    return y


def resonance(x, fn, zeta, fs):
    wn = 2 * np.pi * fn
    bd, ad = signal.bilinear([wn ** 2], [1, 2 * zeta * wn, wn ** 2], fs)
    zi = signal.lfilter_zi(bd, ad) * x[0]
    y, _ = signal.lfilter(bd, ad, x, zi=zi)
    return y


def slew(v, R, fs, v0=None):
    d = R / fs
    out = np.empty_like(v)
    prev = v[0] if v0 is None else v0
    for k in range(len(v)):
        prev = prev + min(max(v[k] - prev, -d), d)
        out[k] = prev
    return out


def drift_fn(p, t):
    kind = p["kind_drift"]
    if kind == "thermal":
        return p["amp"] * (1 - np.exp(-t / p["tau"]))
    if kind == "poly":
        return p["amp"] * (p["c1"] * t / p["T"] + p["c2"] * (t / p["T"]) ** 2)
    return p["amp"] * np.sin(2 * np.pi * t / p["period"] + p["phase"]) - p["amp"] * np.sin(p["phase"])


def simulate(plant, eff, vfull, nhist, fs, strength):
    """Noise-free displacement of the record part (samples nhist:), effect scaled by strength.
    vfull: history (nhist samples, may be 0) + record; history starts from rest at v_lo."""
    kind = eff["kind"]
    v = vfull
    if kind == "slew_limit":
        v = slew(vfull, eff["R0"] / strength, fs, v0=plant["lo"] if nhist else vfull[0])
    elif kind == "rate_dependent_hysteresis":
        v = lag1(vfull, eff["tau0"] * strength, fs, x0=plant["lo"] if nhist else vfull[0])
    yh, _ = hysteresis(plant, v)
    y = yh
    if kind == "rate_dependence":
        if eff["form"] == "lag":
            y = lag1(yh, eff["tau0"] * strength, fs)
        else:
            y = resonance(yh, eff["fn0"] / strength, eff["zeta"], fs)
    elif kind == "creep":
        drv = (vfull - plant["lo"]) if eff["driver"] == "input" else (yh - plant["offset"])
        c = np.zeros_like(yh)
        for tau, g in zip(eff["taus"], eff["weights"]):
            c += g * (lag1(drv, tau, fs, x0=drv[0]) - drv)
        # unit static gain: the creep modes take a share of the static response and give it back slowly
        y = yh + strength * c
    elif kind == "delay":
        d = eff["samples"]
        y = np.concatenate([np.full(d, yh[0]), yh[:-d]]) if d > 0 else yh
    y = y[nhist:]
    if kind == "drift":
        t = np.arange(len(y)) / fs
        y = y + strength * drift_fn(eff, t)
    return y


def make_actuator(seed: int) -> dict:
    """The actuator of ``seed`` and its three records.

    Returns
    -------
    dict with ``seed``, ``truth`` (an effect of :data:`EFFECTS`), ``effect_parameters``,
    ``size_sigma`` (the effect's RMS on the first record over the noise σ), ``sample_rate_hz``,
    ``noise_um``, ``quantisation_um`` (or None), ``plant`` and ``records``: ``{"A", "B", "C"}`` each
    with ``voltage_V``, ``displacement_um`` (measured), ``clean_um`` (noise-free), ``input`` (kind and
    parameters) and ``start`` (``"rest"`` or ``"history"``).
    """
    rng = np.random.default_rng(1000 + seed)
    plant = make_plant(rng)
    lo, hi = plant["lo"], plant["hi"]
    S = hi - lo
    fs = float([1000, 2000, 2500, 5000, 10000][rng.integers(5)])
    effect = EFFECTS[seed % 7]
    kinds = list(rng.choice(INPUT_KINDS, 3, replace=False))
    noise_pct = float(np.exp(rng.uniform(np.log(0.05), np.log(0.5))))
    sigma = noise_pct / 100 * plant["disp_range"]
    quant = None
    if rng.random() < 0.35:
        bits = int(rng.choice([12, 14, 16]))
        q = (plant["disp_range"] * 1.2) / 2 ** bits
        if q < 2 * sigma:
            quant = q

    # records: input, start state
    recs = {}
    for name, kind in zip("ABC", kinds):
        N = int(rng.integers(4000, 30001))
        x, desc = make_input(kind, rng, N, fs)
        start = "rest" if (name == "C" or rng.random() < 0.5) else "history"
        if start == "rest":
            # from rest: the input rises from the low end within the first 3 % of the record
            x = x * smooth_fade(N, int(0.03 * N))
            vhist = np.zeros(0)
        else:
            Nh = int(rng.uniform(0.5, 2.0) * fs)
            fc = rng.uniform(1.0, 10.0)
            bb, aa = signal.butter(2, fc / (fs / 2))
            h = signal.filtfilt(bb, aa, rng.standard_normal(Nh + 1000))[500:500 + Nh]
            h = (h - h.min()) / (h.max() - h.min())
            h = rng.uniform(0.0, 0.3) + rng.uniform(0.5, 0.7) * h
            # from rest at lo, ending at the record's first value
            h = h * smooth_fade(Nh, int(0.1 * Nh))
            h = h + (x[0] - h[-1]) * np.clip((np.arange(Nh) - 0.7 * Nh) / (0.3 * Nh), 0, 1)
            vhist = lo + S * np.clip(h, 0, 1)
        v = lo + S * x
        recs[name] = dict(v=v, vhist=vhist, desc=desc, start=start, N=N)

    # effect parameters (shape), strength found so that RMS of the contribution on A = k sigma
    D_A = recs["A"]["N"] / fs
    eff = {"kind": effect}
    if effect == "rate_dependence":
        eff["form"] = "lag" if rng.random() < 0.5 else "resonance"
        eff["tau0"] = 1e-3
        eff["fn0"] = 100.0
        eff["zeta"] = float(rng.uniform(0.15, 0.8))
    elif effect == "creep":
        m = int(rng.integers(2, 5))
        eff["taus"] = np.sort(np.exp(rng.uniform(np.log(0.02 * D_A), np.log(0.4 * D_A), m))).tolist()
        eff["weights"] = rng.uniform(0.3, 1.0, m).tolist()
        eff["driver"] = "input" if rng.random() < 0.5 else "hysteresis_output"
        if eff["driver"] == "input":
            eff["weights"] = (np.array(eff["weights"]) * plant["disp_range"] / S).tolist()
    elif effect == "delay":
        eff["samples"] = int(rng.integers(1, 6))
    elif effect == "drift":
        dk = ["thermal", "poly", "sine"][rng.integers(3)]
        eff.update(kind_drift=dk)
        if dk == "thermal":
            eff.update(tau=float(rng.uniform(0.3, 2.0) * D_A), amp=1.0)
        elif dk == "poly":
            eff.update(T=D_A, c1=float(rng.uniform(-1, 1)), c2=float(rng.uniform(-1, 1)), amp=1.0)
        else:
            eff.update(period=float(rng.uniform(2, 6) * D_A), phase=float(rng.uniform(0, 2 * np.pi)),
                       amp=1.0)
        eff["kind"] = "drift"
    elif effect == "rate_dependent_hysteresis":
        eff["tau0"] = 1e-3
    elif effect == "slew_limit":
        eff["R0"] = S * 1000.0       # V/s at strength 1
    k_target = float(np.exp(rng.uniform(np.log(3), np.log(30))))

    A = recs["A"]
    vA = np.concatenate([A["vhist"], A["v"]])
    nhA = len(A["vhist"])

    def sim(rec, strength):
        vf = np.concatenate([rec["vhist"], rec["v"]])
        return simulate(plant, eff, vf, len(rec["vhist"]), fs, strength)

    y0A = simulate(plant, {"kind": "none"}, vA, nhA, fs, 0.0)

    def size(strength):
        return float(np.sqrt(np.mean((sim(A, strength) - y0A) ** 2)))

    strength = 0.0
    if effect == "delay":
        best = None
        for d in range(1, 6):
            eff["samples"] = d
            kd = size(1.0) / sigma
            score = abs(np.log(kd / k_target))
            if best is None or score < best[0]:
                best = (score, d)
        eff["samples"] = best[1]
        s = size(1.0)
        k = s / sigma
        if k < 3 or k > 30:
            # adjust the noise within 0.05..0.5 % of range towards the target
            sig_new = np.clip(s / k_target, 0.0005 * plant["disp_range"], 0.005 * plant["disp_range"])
            sigma = float(sig_new)
            noise_pct = sigma / plant["disp_range"] * 100
            if quant is not None and quant >= 2 * sigma:
                quant = None
        strength = 1.0
    elif effect in ("creep", "drift"):
        s1 = size(1.0)
        strength = k_target * sigma / s1
    elif effect != "none":
        target = k_target * sigma
        lo_s, hi_s = 1e-3, 1.0
        while size(hi_s) < target and hi_s < 1e4:
            hi_s *= 3
        for _ in range(40):
            mid = np.sqrt(lo_s * hi_s)
            if size(mid) < target:
                lo_s = mid
            else:
                hi_s = mid
            if hi_s / lo_s < 1.01:
                break
        strength = float(np.sqrt(lo_s * hi_s))
    eff_size_sigma = size(strength) / sigma if effect != "none" else 0.0

    # the records, measured
    records = {}
    for name in "ABC":
        rec = recs[name]
        y = sim(rec, strength) if effect != "none" else sim(rec, 0.0)
        meas = y + sigma * rng.standard_normal(len(y))
        if quant is not None:
            meas = np.round(meas / quant) * quant
        records[name] = dict(voltage_V=rec["v"], displacement_um=meas, clean_um=y, input=rec["desc"],
                             start=rec["start"])

    eff_out = {k: v for k, v in eff.items()}
    if effect == "rate_dependence":
        if eff["form"] == "lag":
            eff_out = dict(kind=effect, form="lag", tau_s=eff["tau0"] * strength)
        else:
            eff_out = dict(kind=effect, form="resonance", fn_Hz=eff["fn0"] / strength, zeta=eff["zeta"])
    elif effect == "rate_dependent_hysteresis":
        eff_out = dict(kind=effect, form="first-order input low-pass", tau_s=eff["tau0"] * strength)
    elif effect == "slew_limit":
        eff_out = dict(kind=effect, rate_V_per_s=eff["R0"] / strength)
    elif effect in ("creep", "drift"):
        eff_out["strength"] = strength
    return dict(seed=seed, truth=effect, effect_parameters=eff_out, size_sigma=eff_size_sigma,
                sample_rate_hz=fs, noise_um=sigma, quantisation_um=quant, plant=plant, records=records)
