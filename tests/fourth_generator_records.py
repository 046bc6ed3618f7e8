"""A fourth generator of measured-like piezo records, written by other hands from the issue alone.

Written without reading the diagnosis (``pysim.diagnosis``) or the other
generators (:mod:`independent_records`, :mod:`third_generator_records`,
:mod:`outside_class_records`), from the issue's description and the paper's
model only, to find what those generators and the method share without
saying so.  Its records brought the operator-set spread, the second record
that does not excite an effect and the look-alike stages a quiet first record
cannot shape (``tests/test_fourth_generator_records.py``).

The plant is the MPI model with one-sided play operators (n = 10 on the
eq. 13 grid, or 15-40 random thresholds), 0-150 V, 0-100 V or -20-120 V,
10-80 µm, every branch's slope above 15 % of the mean gain.  It is simulated
on a grid 8 times finer than the sample rate (4 times at 5 kHz) with the
command interpolated linearly between samples and the stages discretised
exactly there; the sensor reads the displacement at the sample instants.
Sample rate 1, 2 or 5 kHz; white noise of 0.1-0.3 % of the displacement
range, AR(1) noise (φ = 0.5) for one actuator in seven.

One hidden effect or none per actuator (:data:`EFFECTS`): a lag (0.5-5 ms)
or second-order stage (50-400 Hz) after the hysteresis, creep (1-3
non-negative slow modes of the voltage, 0.05-5 s), a delay (0.5-4 samples),
a drift (linear, or a sine slower than the record), a low-pass before the
hysteresis (0.3-3 ms) or an amplifier slew limit; its strength is bisected
so that its RMS on the first record is 2-30 noise σ (0.5-2 σ for one
actuator in six).  Three records per actuator, each of another input shape
(:data:`SHAPES`), 1.5-10 s; the first two start from rest or after an
unrecorded history (1-3 s, no full cycle), the third from rest.
"""
import json
import numpy as np
from scipy import signal

EFFECTS = ['none', 'rate_dependence', 'creep', 'delay', 'drift',
           'rate_dependent_hysteresis', 'slew_limit']
EFFECT_P = [0.22] + [0.13] * 6
SHAPES = ['decaying_triangles', 'multisine', 'steps_sines', 'staircase',
          'bl_noise', 'slow_triangle', 'multi_sines']


# ----------------------------------------------------------------------------- operators
def play(u, r):
    """One-sided play operators F_r[u] (N, n) from the demagnetised start.
    Exact by monotone runs: rising w = max(w_start, u - r), falling w = min(w_start, u)."""
    u = np.asarray(u, float)
    r = np.asarray(r, float)
    W = np.empty((len(u), len(r)))
    W[0] = np.maximum(u[0] - r, min(u[0], 0.0))
    d = np.sign(np.diff(u))
    nz = np.flatnonzero(d)
    if len(nz) == 0:
        W[1:] = W[0]
        return W
    d[:nz[0]] = d[nz[0]]                               # leading flats: any direction will do
    idx = np.maximum.accumulate(np.where(d != 0, np.arange(len(d)), 0))
    d = d[idx]                                        # a flat keeps the previous direction
    cuts = np.flatnonzero(np.diff(d)) + 1
    starts = np.r_[0, cuts]
    ends = np.r_[cuts, len(d)]
    for a, b in zip(starts, ends):                    # diff a..b-1 -> samples a+1..b
        seg = u[a + 1:b + 1, None]
        if d[a] > 0:
            W[a + 1:b + 1] = np.maximum(W[a], seg - r)
        else:
            W[a + 1:b + 1] = np.minimum(W[a], seg)
    return W


def play_loop(u, r):
    """The defining recursion, sample by sample (reference for a self-test)."""
    w = np.maximum(u[0] - r, np.minimum(u[0], 0.0))
    out = [w.copy()]
    for uk in u[1:]:
        w = np.maximum(uk - r, np.minimum(uk, w))
        out.append(w.copy())
    return np.array(out)


def hyst(p, u):
    """MPI output (µm, without sensor offset) for shifted voltage u = v - vmin."""
    return p['a1'] * u ** 3 + p['a2'] * u + play(u, p['r']) @ p['b']


# ----------------------------------------------------------------------------- plant
def make_plant(rng):
    vmin, vmax = [(0., 150.), (0., 100.), (-20., 120.)][rng.choice(3, p=[.6, .2, .2])]
    umax = vmax - vmin
    if rng.random() < 0.35:
        n, grid = 10, True
        rho = np.arange(n) / n
    else:
        n, grid = int(rng.integers(15, 41)), False
        rho = np.sort(rng.uniform(0, 1, n))
        if rng.random() < 0.5:
            rho[0] = 0.0
    k, dpk = rng.uniform(0.3, 4.0), rng.uniform(-0.2, 1.2)
    dens = np.exp(-k * (rho - dpk) ** 2)
    B = dens * np.diff(np.r_[rho, 1.0])
    hfrac = rng.uniform(0.2, 0.65)                     # share of the operators in the gain
    A2 = 1.0
    B *= A2 * hfrac / (1 - hfrac) / B.sum()
    A1 = rng.uniform(-0.5, 0.35)
    while True:                                        # keep every branch clearly increasing
        G = A1 + A2 + np.sum(B * (1 - rho))
        if min_slope(A1, A2, B, rho) > 0.15 * G:
            break
        A1 *= 0.7
    D = rng.uniform(10, 80)
    s = D / G
    return dict(vmin=vmin, vmax=vmax, umax=umax, n=n, grid=grid,
                a1=s * A1 / umax ** 3, a2=s * A2 / umax, b=s * B / umax, r=rho * umax,
                offset=rng.uniform(-30, 30), D=D, gain=D / umax,
                density=dict(k=k, d=dpk, hfrac=hfrac), min_slope_rel=min_slope(A1, A2, B, rho) / G)


def min_slope(A1, A2, B, rho, seed=0):
    """Smallest dy/dx along ascending and descending branches of a random reversal input."""
    rng = np.random.default_rng(seed)
    pts = np.r_[0, 1, 0, 1, rng.uniform(0, 1, 30), 1, 0.02, 0.98, 0]
    x = np.concatenate([np.linspace(a, b, 200)[1:] for a, b in zip(pts[:-1], pts[1:])])
    x = np.r_[0.0, x]
    y = A1 * x ** 3 + A2 * x + play(x, rho) @ B
    dx, dy = np.diff(x), np.diff(y)
    m = np.abs(dx) > 1e-12
    return np.min(dy[m] / dx[m])


# ----------------------------------------------------------------------------- inputs
def _tri(ph):                                          # 0 -> 1 -> 0 over one unit of phase
    f = np.mod(ph, 1.0)
    return 1 - np.abs(2 * f - 1)


def make_shape(shape, rng, fs, T, rest):
    """Normalised input in [0, 1]; starts at 0 when rest is True."""
    N = int(round(T * fs))
    t = np.arange(N) / fs
    if shape == 'decaying_triangles':
        f0 = max(rng.uniform(0.5, 4.0), 3.0 / T)
        env = np.exp(-t / (T * rng.uniform(0.5, 1.5)))
        s = _tri(f0 * t) * env
    elif shape == 'multisine':
        K = rng.integers(3, 7)
        f = np.exp(rng.uniform(np.log(0.5), np.log(min(50, fs / 20)), K))
        a = f ** -rng.uniform(0, 1)
        x = (a[:, None] * np.sin(2 * np.pi * f[:, None] * t + rng.uniform(0, 2 * np.pi, (K, 1)))).sum(0)
        s = (x - x.min()) / (x.max() - x.min())
    elif shape == 'steps_sines':
        s = np.zeros(N)
        i = int(rng.uniform(0.1, 0.3) * fs) if rest else 0
        lvl = 0.0
        step_end = i + int(rng.uniform(0.4, 0.6) * N)  # steps first, sines after them
        for _ in range(rng.integers(2, 5)):
            lvl = rng.uniform(0.1, 1.0)
            j = min(step_end, i + int(rng.uniform(0.2, 1.0) * fs))
            s[i:j] = lvl
            i = j
        while i < N:
            f = rng.uniform(1, min(40, fs / 25))
            c = rng.uniform(0.25, 0.75)
            A = rng.uniform(0.1, 1.0) * min(c, 1 - c)
            j = min(N, i + int(max(2 / f, rng.uniform(0.3, 1.5)) * fs))
            s[i:j] = c + A * np.sin(2 * np.pi * f * np.arange(j - i) / fs)
            i = j
    elif shape == 'staircase':                       # up and down in holds, at least one cycle
        hold = rng.uniform(0.15, 0.5)
        k = max(10, int(T / hold))
        lv, cur, up = [], 0.0 if rest else rng.uniform(0.2, 0.8), True
        for _ in range(k):
            lv.append(cur)
            step = 2.0 / k * rng.uniform(0.6, 1.6)
            if up and cur + step > 1:
                cur, up = 1.0, False
            elif not up and cur - step < 0:
                cur, up = 0.0, True
            else:
                cur = cur + step if up else cur - step
        s = np.repeat(lv, int(np.ceil(N / k)))[:N]
        s = s / s.max() if rest else (s - s.min()) / (s.max() - s.min())
    elif shape == 'bl_noise':
        fc = rng.uniform(2, min(30, fs / 20))
        bb, aa = signal.butter(4, fc / (fs / 2))
        x = signal.filtfilt(bb, aa, rng.standard_normal(N + 2000))[1000:-1000]
        s = (x - x.min()) / (x.max() - x.min())
    elif shape == 'slow_triangle':
        tp = T * rng.uniform(0.4, 0.6)
        s = np.where(t < tp, t / tp, (T - t) / (T - tp))
    elif shape == 'multi_sines':
        fr = np.sort(np.exp(rng.uniform(np.log(0.5), np.log(min(40, fs / 25)), rng.integers(2, 5))))
        amps = rng.uniform(0.4, 1.0, len(fr))
        amps[rng.integers(len(fr))] = 1.0
        ph0 = 0.0 if rest else rng.uniform(0, 1)
        parts = []
        for q, (f, A) in enumerate(zip(fr, amps)):
            per = int(np.ceil(max(2.0, f * T / len(fr))))
            n_ = int(round((per - (ph0 if q == 0 else 0)) * fs / f))
            tt = np.arange(n_) / fs
            parts.append(A * (1 - np.cos(2 * np.pi * (f * tt + (ph0 if q == 0 else 0)))) / 2)
        s = np.concatenate(parts)[:N]
    else:
        raise ValueError(shape)
    if rest and s[0] > 1e-9:                          # a smooth ramp up from rest
        nr = int(rng.uniform(0.1, 0.3) * fs)
        s = np.r_[s[0] * (1 - np.cos(np.pi * np.arange(nr) / nr)) / 2, s]
    return np.clip(s, 0, 1)


def make_history(rng, fs, s_end):
    """A random unrecorded history from rest, 1-3 s, ending at s_end (no full cycle)."""
    T = rng.uniform(1, 3)
    m = rng.integers(2, 6)
    lv = np.r_[0.0, rng.uniform(0.1, 0.95, m), s_end]
    dur = rng.uniform(0.5, 1.5, len(lv) - 1)
    hold = rng.uniform(0, 1, len(lv) - 1) * dur
    dur, hold = dur * T / (dur + hold).sum(), hold * T / (dur + hold).sum()
    out = []
    for a, b, d, h in zip(lv[:-1], lv[1:], dur, hold):
        nd = max(2, int(d * fs))
        out += [a + (b - a) * (1 - np.cos(np.pi * np.arange(nd) / nd)) / 2, np.full(int(h * fs), b)]
    out.append(np.full(max(1, int(rng.uniform(0.05, 0.4) * fs)), s_end))
    return np.concatenate(out)


# ----------------------------------------------------------------------------- effects
def lowpass1(x, tau, h):
    """First-order lag, exact for x linear between samples, at rest at x[0]."""
    a = np.exp(-h / tau)
    c = tau * (1 - a) / h
    b_, a_ = [1 - c, c - a], [1, -a]
    return signal.lfilter(b_, a_, x, zi=signal.lfilter_zi(b_, a_) * x[0])[0]


def second_order(x, fn, zeta, h):
    wn = 2 * np.pi * fn
    A = np.array([[0, 1], [-wn ** 2, -2 * zeta * wn]])
    sysd = signal.cont2discrete((A, np.array([[0], [wn ** 2]]), np.array([[1.0, 0]]), np.zeros((1, 1))), h, method="foh")
    b_, a_ = signal.ss2tf(*sysd[:4])
    b_ = b_[0] / a_[0]
    a_ = a_ / a_[0]
    return signal.lfilter(b_, a_, x, zi=signal.lfilter_zi(b_, a_) * x[0])[0]


def slew(x, rate_step):
    y = np.empty_like(x)
    y[0] = x[0]
    for j in range(1, len(x)):
        y[j] = y[j - 1] + min(rate_step, max(-rate_step, x[j] - y[j - 1]))
    return y


def simulate(plant, eff, v_all, k0, fs, M):
    """Clean displacement (with the effect) and plain displacement (without), at the
    record's samples (those from index k0 on); the history before k0 is dropped."""
    N = len(v_all)
    h = 1.0 / (fs * M)
    tf = np.arange((N - 1) * M + 1) * h
    ts = np.arange(N) / fs
    u = np.interp(tf, ts, v_all - plant['vmin'])
    name, q = eff['name'], eff
    uin = u
    if name == 'delay':
        uin = np.interp(tf - q['delay_samples'] / fs, tf, u)
    elif name == 'rate_dependent_hysteresis':
        uin = lowpass1(u, q['tau_s'], h)
    elif name == 'slew_limit':
        uin = slew(u, q['rate_V_per_s'] * h)
    y = hyst(plant, uin)
    if name == 'rate_dependence':
        y = lowpass1(y, q['tau_s'], h) if q['kind'] == 'lag' else second_order(y, q['fn_hz'], q['zeta'], h)
    elif name == 'creep':
        for c, tau in zip(q['weights_um_per_V'], q['taus_s']):
            y = y - c * (u - lowpass1(u, tau, h))
    elif name == 'drift':
        y = y + drift(q, tf - k0 / fs)
    plain = hyst(plant, v_all - plant['vmin'])
    return (y[::M] + plant['offset'])[k0:], (plain + plant['offset'])[k0:]


def drift(q, t):
    if q['kind'] == 'linear':
        return q['amp_um'] * t / q['T_ref_s']
    f = np.sin(2 * np.pi * t / q['period_s'] + q['phase']) - np.sin(q['phase'])
    return q['amp_um'] * f / q['norm']


def make_effect(rng, name, plant, fs):
    """Effect with its magnitude parameter still to be set (returns setter and range)."""
    e = dict(name=name)
    near = rng.random() < 1 / 6
    e['target_sigma'] = float(np.exp(rng.uniform(np.log(0.5), np.log(2)) if near
                                     else rng.uniform(np.log(2), np.log(30))))
    if name == 'rate_dependence':
        e['kind'] = 'lag' if rng.random() < 0.5 else 'second_order'
        if e['kind'] == 'lag':
            return e, 'tau_s', (1e-4 if near else 5e-4, 5e-3), +1
        e['zeta'] = rng.uniform(0.3, 0.9)
        return e, 'fn_hz', (min(400, fs / 4) * (2.5 if near else 1), 50), +1
    if name == 'creep':
        K = rng.integers(1, 4)
        e['taus_s'] = list(np.sort(np.exp(rng.uniform(np.log(0.05), np.log(5), K))))
        e['split'] = list(rng.dirichlet(np.ones(K) * 2))
        return e, 'creep_frac', (0.003 if near else 0.02, 0.10), +1
    if name == 'delay':
        return e, 'delay_samples', (0.1 if near else 0.5, 4.0), +1
    if name == 'drift':
        e['kind'] = 'linear' if rng.random() < 0.5 else 'sine'
        e['phase'] = rng.uniform(0, 2 * np.pi)
        e['period_mult'] = rng.uniform(1.5, 4.0)
        return e, 'drift_frac', (0.002 if near else 0.01, 0.05), +1
    if name == 'rate_dependent_hysteresis':
        return e, 'tau_s', (5e-5 if near else 3e-4, 3e-3), +1
    if name == 'slew_limit':
        return e, 'rate_V_per_s', (40.0 * fs * (3 if near else 1), 4.0 * fs), +1
    e.pop('target_sigma')
    return e, None, None, 0


def set_param(e, key, val, plant, T1):
    e[key] = float(val)
    if key == 'creep_frac':
        e['weights_um_per_V'] = [float(val * plant['gain'] * w) for w in e['split']]
    if key == 'drift_frac':
        e['amp_um'] = float(val * plant['D'])
        e['T_ref_s'] = T1
        if e['kind'] == 'sine':
            e['period_s'] = T1 * e['period_mult']
            tt = np.linspace(0, T1, 2000)
            f = np.sin(2 * np.pi * tt / e['period_s'] + e['phase'])
            e['norm'] = float(f.max() - f.min())


# ----------------------------------------------------------------------------- actuator
def make_actuator(seed):
    rng = np.random.default_rng(seed)
    plant = make_plant(rng)
    fs = float(rng.choice([1000, 2000, 5000], p=[.15, .7, .15]))
    M = 4 if fs > 2000 else 8
    name = str(rng.choice(EFFECTS, p=EFFECT_P))
    sig_frac = rng.uniform(0.001, 0.003)
    sigma = sig_frac * plant['D']
    ar_phi = 0.5 if rng.random() < 0.15 else 0.0
    shapes = list(rng.permutation(SHAPES)[:3])
    if name == 'slew_limit' and shapes[0] not in ('steps_sines', 'staircase'):
        shapes[0] = str(rng.choice(['steps_sines', 'staircase']))
        shapes[1:] = [s for s in rng.permutation(SHAPES) if s != shapes[0]][:2]
    starts = ['rest' if rng.random() < 0.5 else 'history',
              'rest' if rng.random() < 0.5 else 'history', 'rest']
    Tmax = 5.0 if fs > 2000 else 10.0
    recs = []
    for shp, st in zip(shapes, starts):
        s = make_shape(shp, rng, fs, rng.uniform(1.5, Tmax), st == 'rest')
        hist = make_history(rng, fs, s[0]) if st == 'history' else np.zeros(0)
        v_all = plant['vmin'] + plant['umax'] * np.r_[hist, s]
        recs.append(dict(shape=shp, start=st, v_all=v_all, k0=len(hist)))
    T1 = (len(recs[0]['v_all']) - recs[0]['k0']) / fs

    eff, key, rngp, _ = make_effect(rng, name, plant, fs)
    if key is not None:                                # set the magnitude to hit the target size
        def size(val):
            set_param(eff, key, val, plant, T1)
            yc, yp = simulate(plant, eff, recs[0]['v_all'], recs[0]['k0'], fs, M)
            return np.sqrt(np.mean((yc - yp) ** 2)) / sigma
        lo, hi = rngp                                 # lo: small effect end, hi: large effect end
        if size(hi) <= eff['target_sigma']:
            val = hi
        elif size(lo) >= eff['target_sigma']:
            val = lo
        else:
            for _ in range(14):                      # geometric bisection
                mid = np.sqrt(lo * hi)
                if size(mid) < eff['target_sigma']:
                    lo = mid
                else:
                    hi = mid
            val = np.sqrt(lo * hi)
        set_param(eff, key, val, plant, T1)

    out = dict(seed=seed, fs=fs, truth=name, sigma_um=sigma, noise='ar1' if ar_phi else 'white')
    for i, rc in enumerate(recs, 1):
        yc, yp = simulate(plant, eff, rc['v_all'], rc['k0'], fs, M)
        e = rng.standard_normal(len(yc)) * sigma
        if ar_phi:
            e = signal.lfilter([np.sqrt(1 - ar_phi ** 2)], [1, -ar_phi], e)
        out[f'v{i}'] = rc['v_all'][rc['k0']:]
        out[f'hist{i}'] = rc['v_all'][:rc['k0']]           # the unrecorded history (empty from rest)
        out[f'y{i}'] = yc + e
        out[f'yclean{i}'] = yc
        out[f'yplain{i}'] = yp
        out[f'size{i}_sigma'] = float(np.sqrt(np.mean((yc - yp) ** 2)) / sigma)
        out[f'shape{i}'], out[f'start{i}'] = rc['shape'], rc['start']
    truth = dict(plant={k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in plant.items()},
                 effect={k: (float(v) if isinstance(v, np.floating) else v) for k, v in eff.items()},
                 fs=fs, sigma_um=sigma, ar_phi=ar_phi, oversample=M,
                 shapes=[r['shape'] for r in recs], starts=[r['start'] for r in recs],
                 history_samples=[r['k0'] for r in recs])
    out['truth_json'] = json.dumps(truth, default=float)
    return out
