#!/usr/bin/env python3
"""The third generator: synthetic elastic-joint characterisation records with answers, written
without reading `framework/ident` or the project's other generators (issue 31: test data that
shares no assumptions with the code it tests).

Set-up (thesis 3.3.1): the joint output is moved by hand while the motor holds; columns
t [s], deflection [rad] (encoder), torque [Nm] (F/T sensor + white noise).

Known structure of every record (thesis eq. 3.5), evaluated on the TRUE deflection x and rate v:
    tau_0 = k*x + k_a*atan(k_b*v),  k ~ logU(20,1500) Nm/rad, k_a ~ logU(0.02,1) Nm, k_b ~ logU(10,200) s/rad

Hidden effects (none, one or a pair), added to tau_0:
  viscous_friction       + b*v
  hysteresis             + force*h(x), h a normalised rate-independent operator (|h|<=1), one of
                           dahl          dh/dx = (1 - h*sgn(dx))/x0             (exact exponential update)
                           bouc_wen      dh/dx = (1 - (beta*sgn(dx*h)+gamma)|h|^n)/x0, beta+gamma=1, n in {1,2}
                           maxwell_slip  N elasto-slip elements, slip deflections spread 0.2..3 x0,
                                         slip forces summing to 1
                           x0 = transition deflection (2-15 % of the peak deflection); params.sigma = force/x0
  dead_zone              spring term k*x replaced by k*dz(x): sharp dz = sgn(x)max(|x|-w,0), or
                           smooth dz = .5[(x-w)+sqrt((x-w)^2+e^2)] + .5[(x+w)-sqrt((x+w)^2+e^2)], e=0.2w
  stiffness_nonlinearity + k3*x^3 (stiffening k3>0 or softening k3<0)
  time_delay             the whole mechanical torque (incl. the above) is either transport-delayed,
                           tau(t-delay), or passed through a first-order lag with time constant `delay`
  sensor_offset          + offset + drift*(t_real - t_mid)   (drift 0 unless model 'linear_drift';
                           `offset` = mean offset over the record)
  vibration              + amplitude*sin(2*pi*frequency*t_real + phase), 5-60 Hz (< 0.4 fs)
Sensor effects (offset, vibration, noise) are added after the delay.

Effect size: the torque an effect adds (full noise-free record minus the record computed without that
effect), RMS over the written rows (sqrt(mean(c^2)), not mean-removed), is 1.6-9.5 x the noise RMS.
Noise RMS = 0.5-5 % of the noise-free torque range (max-min).  Plausibility limits (else redraw):
dead-zone width <= 0.3 x_max, hysteresis force <= 0.35 k x_max, b*max|v| <= 0.6 k x_max,
stiffening k3 x_max^2 <= 3k, softening |k3| x_max^2 <= 0.25k, delay 0.2 ms-0.25 s, and the
noise-free torque range at most 2x that of the baseline alone.

Variants (timing): plain (uniform), jitter (time-stamp jitter + dropped-sample gaps 0.02-0.2 s),
epoch (t + ~1.7e9), repeat3 (one test 3x, time restarting, rest pauses between not written),
bin20 (1 kHz simulation averaged in 50 ms bins -> 20 Hz).  Encoder: enc14 (2pi/16384, default),
enc17 (2pi/131072), linenc (2e-6 rad).  Excitation: tapered sines, rounded triangles, chirps,
random-phase multi-sines, staircase holds, random-walk-like (1/f) motion, 0.05-3 Hz, 0.01-0.2 rad.

Usage:  .venv-interop/bin/python tools/ident_reference/third_generator/generate.py --out DIR [--seeds 1 2]
        -> DIR/s1, DIR/s2 (CSV + answers.json; about 100 MB a seed, so DIR outside the repository)
"""
import argparse
import itertools
import json
import math
import os
import sys
import time

import numpy as np

EFFECTS = ["viscous_friction", "hysteresis", "dead_zone", "stiffness_nonlinearity",
           "sensor_offset", "time_delay", "vibration"]
SENSOR = ("sensor_offset", "vibration")
ENC_STEP = {"enc14": 2 * math.pi / 16384, "enc17": 2 * math.pi / 131072, "linenc": 2e-6}
RATIO_LO, RATIO_HI = 1.6, 9.5           # accepted effect_rms_over_noise (spec 1.5-10)
MAX_ROWS = 290000


def logu(rng, a, b):
    return float(math.exp(rng.uniform(math.log(a), math.log(b))))


def rms(a):
    return float(np.sqrt(np.mean(np.square(a))))


# ----------------------------------------------------------------------------------------------
# linear recursion y_i = a_i*y_{i-1} + b_i, vectorised in chunks (used by Dahl and first-order lag)
def linrec(a, b, y0):
    la = np.maximum(np.log(np.clip(a, 1e-300, 1.0)), -60.0)
    n = len(a)
    y = np.empty(n)
    C = np.cumsum(-la)
    start, prev = 0, float(y0)
    while start < n:
        base = C[start - 1] if start > 0 else 0.0
        end = int(np.searchsorted(C, base + 600.0, side="right"))
        end = max(end, start + 1)
        E = C[start:end] - base
        s = np.cumsum(b[start:end] * np.exp(E))
        y[start:end] = np.exp(-E) * (prev + s)
        prev = y[end - 1]
        start = end
    return y


def lag_filter(t, u, tau):
    """first-order lag y' = (u-y)/tau, exact for piecewise-linear u (first-order hold)."""
    dt = np.diff(t)
    a = np.exp(-dt / tau)
    c = (tau / dt) * (1.0 - a)
    b = u[1:] - a * u[:-1] - (u[1:] - u[:-1]) * c
    y = np.empty_like(u)
    y[0] = u[0]
    y[1:] = linrec(a, b, u[0])
    return y


# ----------------------------------------------------------------------------------------------
# hysteresis operators, unit saturation force
def hyst_unit(x, spec):
    m = spec["model"]
    x0 = spec["x0"]
    if m == "dahl":
        dx = np.diff(x)
        a = np.exp(-np.abs(dx) / x0)
        b = (1.0 - a) * np.sign(dx)
        h = np.empty_like(x)
        h[0] = 0.0
        h[1:] = linrec(a, b, 0.0)
        return h
    if m == "bouc_wen":
        beta, gamma, n = spec["beta"], spec["gamma"], spec["n"]
        xs = x.tolist()
        out = [0.0] * len(xs)
        z = 0.0
        step = 0.05 * x0

        def f(z, dxs):
            s = 1.0 if dxs * z > 0 else -1.0
            return (1.0 - (beta * s + gamma) * abs(z) ** n) / x0
        for i in range(1, len(xs)):
            dx = xs[i] - xs[i - 1]
            if dx != 0.0:
                ns = int(abs(dx) / step) + 1
                hdx = dx / ns
                for _ in range(ns):
                    k1 = f(z, hdx)
                    zm = z + 0.5 * hdx * k1
                    z = z + hdx * f(zm, hdx)
            out[i] = z
        return np.asarray(out)
    if m == "maxwell_slip":
        xs = x.tolist()
        total = np.zeros(len(xs))
        for d, fr in zip(spec["slip"], spec["frac"]):
            kk = fr / d
            e = 0.0
            prev = xs[0]
            col = [0.0] * len(xs)
            for i in range(1, len(xs)):
                xi = xs[i]
                e += xi - prev
                prev = xi
                if e > d:
                    e = d
                elif e < -d:
                    e = -d
                col[i] = e
            total += kk * np.asarray(col)
        return total
    raise ValueError(m)


# ----------------------------------------------------------------------------------------------
# excitation: smooth (C1) function of time, zero outside its segments
def taper(s, T, L):
    w = np.ones_like(s)
    if L <= 0:
        return w
    m = s < L
    w[m] = np.sin(0.5 * np.pi * s[m] / L) ** 2
    m = s > T - L
    w[m] = np.sin(0.5 * np.pi * (T - s[m]) / L) ** 2
    return w


class Segment:
    def __init__(self, t0, T, kind, fn, info):
        self.t0, self.T, self.kind, self.fn, self.info = t0, T, kind, fn, info


def _norm_grid(T, fmax):
    return np.linspace(0.0, T, int(T * fmax * 60) + 200)


def make_segment(rng, kind, t0, T, f_lo, f_hi, amp):
    if kind in ("sine", "triangle"):
        f = logu(rng, f_lo, f_hi)
        f = max(f, 1.5 / T)
        ncyc = max(1, min(int(T * f), int(rng.integers(2, 13))))
        T = ncyc / f
        L = min(0.3 * T, rng.uniform(0.4, 1.0) / f)
        ph = rng.uniform(0, 2 * np.pi)
        if kind == "sine":
            def fn(s, f=f, T=T, L=L, ph=ph, A=amp):
                return A * np.sin(2 * np.pi * f * s + ph) * taper(s, T, L)
            info = {"kind": kind, "f": f}
        else:
            rho = rng.uniform(0.95, 0.995)
            nrm = np.arcsin(rho)

            def fn(s, f=f, T=T, L=L, ph=ph, A=amp, rho=rho, nrm=nrm):
                return A * np.arcsin(rho * np.sin(2 * np.pi * f * s + ph)) / nrm * taper(s, T, L)
            info = {"kind": kind, "f": f}
        return Segment(t0, T, kind, fn, info), T
    if kind == "chirp":
        fa, fb = logu(rng, f_lo, f_hi), logu(rng, f_lo, f_hi)
        if rng.random() < 0.5:
            fa, fb = fb, fa
        fa = max(fa, 1.0 / T)
        fb = max(fb, 1.0 / T)
        log = rng.random() < 0.4 and abs(fb - fa) > 1e-6
        L = min(0.2 * T, 1.0 / min(fa, fb))
        if log:
            r = math.log(fb / fa)

            def fn(s, fa=fa, r=r, T=T, L=L, A=amp):
                th = 2 * np.pi * fa * T / r * (np.exp(r * s / T) - 1.0)
                return A * np.sin(th) * taper(s, T, L)
        else:
            def fn(s, fa=fa, fb=fb, T=T, L=L, A=amp):
                th = 2 * np.pi * (fa * s + (fb - fa) * s * s / (2 * T))
                return A * np.sin(th) * taper(s, T, L)
        return Segment(t0, T, kind, fn, {"kind": kind, "f0": fa, "f1": fb, "log": bool(log)}), T
    if kind in ("multisine", "randwalk"):
        if kind == "multisine":
            nc = int(rng.integers(3, 9))
            fr = np.exp(rng.uniform(math.log(f_lo), math.log(f_hi), nc))
            a = rng.uniform(0.3, 1.0, nc)
        else:
            nc = int(rng.integers(40, 80))
            fr = np.exp(np.linspace(math.log(max(f_lo, 0.05)), math.log(f_hi), nc))
            fr *= np.exp(rng.uniform(-0.05, 0.05, nc))
            a = 1.0 / fr
        fr = np.maximum(fr, 1.0 / T)
        ph = rng.uniform(0, 2 * np.pi, len(fr))
        bias = rng.uniform(-0.3, 0.3) if kind == "randwalk" else 0.0
        L = min(0.2 * T, 1.0 / fr.min())
        g = _norm_grid(T, fr.max())
        raw = np.sin(2 * np.pi * np.outer(g, fr) + ph) @ a
        nrm = np.max(np.abs(raw)) * (1.0 + abs(bias))

        def fn(s, fr=fr, a=a, ph=ph, T=T, L=L, A=amp, nrm=nrm, bias=bias):
            y = np.zeros_like(s)
            for fi, ai, pi in zip(fr, a, ph):
                y += ai * np.sin(2 * np.pi * fi * s + pi)
            return A * (y / nrm + bias / (1 + abs(bias))) * taper(s, T, L)
        return Segment(t0, T, kind, fn, {"kind": kind, "n_comp": int(nc),
                                         "f_min": float(fr.min()), "f_max": float(fr.max())}), T
    if kind == "staircase":
        m = int(rng.integers(2, 6))
        lev = [0.0] + list(rng.uniform(-1, 1, m) * amp) + [0.0]
        knots = []           # (start, dur_transition, from, to)
        s = 0.0
        for i in range(len(lev) - 1):
            tr = rng.uniform(0.3, 1.2)
            knots.append((s, tr, lev[i], lev[i + 1]))
            s += tr + rng.uniform(0.5, 4.0)
        Tn = s

        def fn(s, knots=knots):
            y = np.zeros_like(s)
            for (s0, tr, a0, a1) in knots:
                u = np.clip((s - s0) / tr, 0.0, 1.0)
                y += (a1 - a0) * 0.5 * (1 - np.cos(np.pi * u)) * (s >= s0)
            return y
        return Segment(t0, Tn, kind, fn, {"kind": kind, "levels": m}), Tn
    raise ValueError(kind)


class Excitation:
    def __init__(self, segs, T, scale=1.0):
        self.segs, self.T, self.scale = segs, T, scale
        self.period = None
        self.nrep = 1

    def base(self, t):
        x = np.zeros_like(t)
        for sg in self.segs:
            m = (t >= sg.t0) & (t < sg.t0 + sg.T)
            if m.any():
                x[m] += sg.fn(t[m] - sg.t0)
        return x

    def __call__(self, t):
        t = np.asarray(t, float)
        if self.period is None:
            return self.scale * self.base(t)
        loc = np.mod(t, self.period)
        x = self.scale * self.base(loc)
        x[(t < 0) | (t >= self.nrep * self.period)] = 0.0
        return x

    def rate(self, t, h=1e-4):
        return (self(t + h) - self(t - h)) / (2 * h)


def make_excitation(rng, T, f_lo, f_hi):
    allk = ["sine", "triangle", "chirp", "multisine", "staircase", "randwalk"]
    w = np.array([3, 2, 1.5, 1.5, 1, 1.5])
    nk = int(rng.integers(1, 4))
    kinds = list(rng.choice(allk, size=nk, replace=False, p=w / w.sum()))
    segs = []
    t = rng.uniform(0.3, 2.0)
    endhold = rng.uniform(0.3, 2.0)
    guard = 0
    while guard < 200:
        guard += 1
        rem = T - endhold - t
        if rem < 3.0:
            break
        kind = kinds[int(rng.integers(len(kinds)))]
        if kind in ("sine", "triangle"):
            Tm = rem
        elif kind == "chirp":
            Tm = min(rem, logu(rng, 8, 60))
        elif kind == "multisine":
            Tm = min(rem, logu(rng, 8, 60))
        elif kind == "randwalk":
            Tm = min(rem, logu(rng, 10, 80))
        else:
            Tm = rem
        amp = rng.uniform(0.4, 1.0)
        seg, Tseg = make_segment(rng, kind, t, Tm, f_lo, f_hi, amp)
        if seg.T > rem:
            continue
        segs.append(seg)
        t += seg.T
        if rng.random() < 0.7:
            t += rng.uniform(0.3, 4.0)
    if not segs:      # fallback: one tapered sine filling the record
        seg, _ = make_segment(rng, "sine", 0.5, T - 1.0, max(f_lo, 2.0 / T), max(f_hi, 2.0 / T), 1.0)
        segs.append(seg)
    return Excitation(segs, T)


# ----------------------------------------------------------------------------------------------
def make_grid(rng, timing, fs, duration):
    """returns dict: t_sim (real time), out (sim->record operator), t_rec (written), extra info"""
    g = {"timing": timing}
    if timing == "bin20":
        nb = int(round(duration * 20))
        t_sim = np.arange(nb * 50) / 1000.0
        g["t_sim"] = t_sim
        g["out"] = lambda a: a.reshape(nb, 50).mean(axis=1)
        g["t_rec"] = g["out"](t_sim)
        g["fs"] = 20.0
        g["sim_per_row"] = 50
        g["exc_T"] = nb * 50 / 1000.0
        return g
    g["fs"] = float(fs)
    g["sim_per_row"] = 1
    if timing == "repeat3":
        n_rep = int(round(duration / 3 * fs))
        n_pause = int(round(rng.uniform(1.0, 5.0) * fs))
        per = n_rep + n_pause
        i = np.arange(3 * n_rep + 2 * n_pause)
        t_sim = i / fs
        keep = (i % per) < n_rep
        idx = np.nonzero(keep)[0]
        g.update(t_sim=t_sim, idx=idx, t_rec=(i[idx] % per) / fs, exc_T=n_rep / fs,
                 period=per / fs, pause=n_pause / fs)
    else:
        n = int(round(duration * fs))
        t_sim = np.arange(n) / fs
        if timing == "jitter":
            js = rng.uniform(0.02, 0.2) / fs
            t_sim = t_sim + np.clip(rng.normal(0, js, n), -0.4 / fs, 0.4 / fs)
            t_sim = np.round(t_sim - t_sim[0], 7)
            ng = int(rng.integers(2, 11))
            keep = np.ones(n, bool)
            gaps = []
            for _ in range(ng):
                gd = rng.uniform(max(3.0 / fs, 0.02), 0.2)
                g0 = rng.uniform(1.0, t_sim[-1] - 1.0 - gd)
                keep[(t_sim > g0) & (t_sim < g0 + gd)] = False
                gaps.append([round(g0, 4), round(gd, 4)])
            g["gaps"] = sorted(gaps)
            g["jitter_rms"] = js
            idx = np.nonzero(keep)[0]
        else:
            idx = np.arange(n)
        g.update(t_sim=t_sim, idx=idx, t_rec=t_sim[idx], exc_T=float(t_sim[-1]) + 1.0 / fs)
        if timing == "epoch":
            g["t0_epoch"] = round(1.7e9 + rng.uniform(-5e6, 6e7), 3)
    idx = g["idx"]
    g["out"] = lambda a, idx=idx: a[idx]
    return g


def dead_zone_fn(x, w, model):
    if model == "sharp":
        return np.sign(x) * np.maximum(np.abs(x) - w, 0.0)
    e = 0.2 * w
    return 0.5 * ((x - w) + np.sqrt((x - w) ** 2 + e * e)) + 0.5 * ((x + w) - np.sqrt((x + w) ** 2 + e * e))


class Record:
    """noise-free physics of one record; P = dict of effect params (present effects only)"""

    def __init__(self, exc, g, k, ka, kb, models, hspec, vib_phase, drift_shape):
        self.exc, self.g, self.k, self.ka, self.kb = exc, g, k, ka, kb
        self.t = g["t_sim"]
        self.out = g["out"]
        self.x = exc(self.t)
        self.v = exc.rate(self.t)
        self.models, self.hspec = models, hspec
        self.H = hyst_unit(self.x, hspec) if hspec else None
        self.vib_phase = vib_phase
        self.drift_shape = drift_shape          # offset(t) = p*(1 + drift_shape(t))
        self._shift = {}
        self.exact_shift_hyst = False

    def shifted(self, d):
        key = (round(d, 12), self.exact_shift_hyst)
        if key not in self._shift:
            if len(self._shift) > 64:
                self._shift.clear()
            ts = self.t - d
            xs, vs = self.exc(ts), self.exc.rate(ts)
            Hs = None
            if self.hspec:
                Hs = hyst_unit(xs, self.hspec) if self.exact_shift_hyst else np.interp(ts, self.t, self.H, left=0.0)
            self._shift[key] = (xs, vs, Hs)
        return self._shift[key]

    def mech(self, P, x, v, H):
        if "dead_zone" in P:
            tau = self.k * dead_zone_fn(x, P["dead_zone"], self.models["dead_zone"])
        else:
            tau = self.k * x
        tau = tau + self.ka * np.arctan(self.kb * v)
        if "viscous_friction" in P:
            tau = tau + P["viscous_friction"] * v
        if "stiffness_nonlinearity" in P:
            tau = tau + P["stiffness_nonlinearity"] * x ** 3
        if "hysteresis" in P:
            tau = tau + P["hysteresis"] * H
        return tau

    def sim(self, P):
        """noise-free torque on the sim grid"""
        if "time_delay" in P and self.models["time_delay"] == "transport":
            xs, vs, Hs = self.shifted(P["time_delay"])
            tau = self.mech(P, xs, vs, Hs)
        else:
            tau = self.mech(P, self.x, self.v, self.H)
            if "time_delay" in P:
                tau = lag_filter(self.t, tau, P["time_delay"])
        if "sensor_offset" in P:
            tau = tau + P["sensor_offset"] * (1.0 + self.drift_shape)
        if "vibration" in P:
            f, _a = self.models["vibration_f"], None
            tau = tau + P["vibration"] * np.sin(2 * np.pi * f * self.t + self.vib_phase)
        return tau

    def rec(self, P):
        return self.out(self.sim(P))

    def contrib(self, P, e):
        Q = dict(P)
        del Q[e]
        return self.rec(P) - self.rec(Q)


LINEAR = ("viscous_friction", "stiffness_nonlinearity", "hysteresis", "sensor_offset", "vibration")


def size_effects(R, effects, signs, targets, phi, limits):
    """fixed point: sigma = phi*range(torque); each effect's param solved for its target ratio"""
    P = {}
    for e in effects:   # rough initial guesses
        P[e] = {"dead_zone": 0.02 * limits["xmax"], "time_delay": 0.01}.get(e, 0.0)
        if e in LINEAR:
            P[e] = 0.0
    sigma = None
    for it in range(7):
        sigma = phi * float(np.ptp(R.rec(P)))
        for e in effects:
            want = targets[e] * sigma
            if e in LINEAR:
                Q = dict(P)
                Q[e] = signs.get(e, 1.0)
                c = rms(R.contrib(Q, e))
                if c <= 0:
                    return None, None
                P[e] = signs.get(e, 1.0) * want / c
            else:
                lo, hi = limits[e]
                Q = dict(P)
                Q[e] = hi
                if rms(R.contrib(Q, e)) < want:
                    return None, None
                a, b = math.log(lo), math.log(hi)
                for _ in range(24):
                    m = 0.5 * (a + b)
                    Q[e] = math.exp(m)
                    if rms(R.contrib(Q, e)) < want:
                        a = m
                    else:
                        b = m
                P[e] = math.exp(0.5 * (a + b))
    return P, sigma


def plan(seed, n_single=7, n_pairs=6, n_clean=8):
    rng = np.random.default_rng(seed * 7919 + 13)
    specs = [(e,) for e in EFFECTS for _ in range(n_single)]
    allpairs = list(itertools.combinations(EFFECTS, 2))
    sel = rng.choice(len(allpairs), size=n_pairs, replace=False)
    specs += [allpairs[i] for i in sorted(sel)]
    specs += [()] * n_clean
    order = rng.permutation(len(specs))
    specs = [specs[i] for i in order]
    n = len(specs)
    nt = max(1, round(n * 0.127))
    timings = ["jitter"] * nt + ["epoch"] * nt + ["repeat3"] * nt + ["bin20"] * nt
    timings += ["plain"] * (n - len(timings))
    timings = [timings[i] for i in rng.permutation(n)]
    # vibration cannot be resolved in 20 Hz bin averages: swap with a non-vibration plain record
    for i in range(n):
        if timings[i] == "bin20" and "vibration" in specs[i]:
            for j in range(n):
                if timings[j] == "plain" and "vibration" not in specs[j]:
                    timings[i], timings[j] = timings[j], timings[i]
                    break
    ne = max(1, round(n * 0.15))
    encs = ["enc17"] * ne + ["linenc"] * ne
    encs += ["enc14"] * (n - len(encs))
    encs = [encs[i] for i in rng.permutation(n)]
    return [(i, specs[i], timings[i], encs[i]) for i in range(n)]


def draw_fs(rng):
    if rng.random() < 0.7:
        return float(rng.choice([100, 125, 200, 250, 500, 1000, 1000, 2000]))
    return float(int(round(logu(rng, 100, 2000))))


def build_record(seed, idx, effects, timing, enc, want_internal=False):
    effects = list(effects)
    for attempt in range(60):
        rng = np.random.default_rng([seed, idx, attempt])
        k, ka, kb = logu(rng, 20, 1500), logu(rng, 0.02, 1.0), logu(rng, 10, 200)
        fs = draw_fs(rng)
        dur = logu(rng, 20, 300)
        if timing != "bin20":
            dur = min(dur, MAX_ROWS / fs)
        else:
            dur = min(dur, 300.0)
        if dur < 20:
            continue
        g = make_grid(rng, timing, fs, dur)
        f_lo = logu(rng, 0.05, 1.0)
        f_hi = min(3.0, f_lo * logu(rng, 2.0, 25.0))
        Texc = g["exc_T"]
        exc = make_excitation(rng, Texc, f_lo, f_hi)
        if timing == "repeat3":
            exc.period, exc.nrep = g["period"], 3
        A = logu(rng, 0.01, 0.2)
        xr = exc(g["t_sim"])
        mx = float(np.max(np.abs(xr)))
        if mx <= 0:
            continue
        exc.scale = A / mx
        models = {}
        hspec = None
        if "hysteresis" in effects:
            hm = ["dahl", "bouc_wen", "maxwell_slip"][int(rng.integers(3))]
            hspec = {"model": hm, "x0": A * logu(rng, 0.02, 0.15)}
            if hm == "bouc_wen":
                b_ = rng.uniform(0.5, 0.9)
                hspec.update(beta=b_, gamma=1.0 - b_, n=int(rng.choice([1, 2])))
            if hm == "maxwell_slip":
                N = int(rng.integers(4, 11))
                sl = np.sort(np.exp(rng.uniform(math.log(0.2), math.log(3.0), N))) * hspec["x0"]
                fr = rng.dirichlet(np.ones(N) * 2.0)
                hspec.update(slip=[float(s) for s in sl], frac=[float(f) for f in fr])
            models["hysteresis"] = hm
        if "dead_zone" in effects:
            models["dead_zone"] = "sharp" if rng.random() < 0.5 else "smooth"
        if "time_delay" in effects:
            models["time_delay"] = "transport" if rng.random() < 0.55 else "first_order_lag"
        signs = {}
        if "stiffness_nonlinearity" in effects:
            signs["stiffness_nonlinearity"] = 1.0 if rng.random() < 0.5 else -1.0
            models["stiffness_nonlinearity"] = "stiffening" if signs["stiffness_nonlinearity"] > 0 else "softening"
        if "viscous_friction" in effects:
            models["viscous_friction"] = "linear"
        drift_shape = np.zeros_like(g["t_sim"])
        if "sensor_offset" in effects:
            signs["sensor_offset"] = 1.0 if rng.random() < 0.5 else -1.0
            if rng.random() < 0.4:
                tt = g["t_sim"]
                rho = rng.uniform(0.1, 0.5) * (1 if rng.random() < 0.5 else -1)
                span = float(tt[-1] - tt[0])
                drift_shape = rho * (tt - 0.5 * (tt[0] + tt[-1])) / span
                models["sensor_offset"] = "linear_drift"
            else:
                models["sensor_offset"] = "constant"
        vib_phase = float(rng.uniform(0, 2 * np.pi))
        if "vibration" in effects:
            fmax = min(60.0, 0.4 * g["fs"])
            models["vibration_f"] = float(round(rng.uniform(5.0, fmax), 3))
            models["vibration"] = "sinusoid"
        R = Record(exc, g, k, ka, kb, models, hspec, vib_phase, drift_shape)
        q = ENC_STEP[enc]
        xmax = float(np.max(np.abs(R.x)))
        fsim = g["fs"] * g["sim_per_row"]
        limits = {"xmax": xmax,
                  "dead_zone": (1e-6, 0.3 * xmax),
                  "time_delay": (2e-4, min(0.25, 0.25 / f_hi))}
        for tr in range(20):
            phi = logu(rng, 0.006, 0.045)
            targets = {e: logu(rng, 1.8, 8.5) for e in effects}
            R.exact_shift_hyst = False
            P, sigma = size_effects(R, effects, signs, targets, phi, limits) if effects else ({}, None)
            if P is None:
                continue
            R.exact_shift_hyst = True
            full = R.rec(P)
            if not effects:
                sigma = phi * float(np.ptp(full))
            ratios = {e: rms(R.contrib(P, e)) / sigma for e in effects}
            phi_act = sigma / float(np.ptp(full))
            ok = all(RATIO_LO <= r <= RATIO_HI for r in ratios.values()) and 0.0052 <= phi_act <= 0.048
            if "dead_zone" in P:
                ok &= q <= P["dead_zone"] <= 0.3 * xmax
            if "stiffness_nonlinearity" in P:
                k3 = P["stiffness_nonlinearity"]
                ok &= (k3 * xmax ** 2 <= 3 * k) if k3 > 0 else (-k3 * xmax ** 2 <= 0.25 * k)
            if "hysteresis" in P:
                ok &= P["hysteresis"] <= 0.35 * k * xmax
            if "time_delay" in P:
                ok &= 2e-4 <= P["time_delay"] <= 0.25
            if "viscous_friction" in P:
                ok &= 0 < P["viscous_friction"] * float(np.max(np.abs(R.v))) <= 0.6 * k * xmax
            # the hidden effects must not dominate the record: torque range at most 2x the baseline's
            ok &= float(np.ptp(full)) <= 2.0 * float(np.ptp(R.rec({})))
            if not ok:
                continue
            # ---- accepted: measurement ----
            sig_sim = sigma * math.sqrt(g["sim_per_row"])
            noise = rng.normal(0.0, sig_sim, len(g["t_sim"]))
            x_meas = np.round(R.x / q) * q
            defl = g["out"](x_meas)
            torque = full + g["out"](noise)
            params = {}
            for e in effects:
                if e == "viscous_friction":
                    params["b"] = P[e]
                elif e == "hysteresis":
                    params["force"] = P[e]
                    params["sigma"] = P[e] / hspec["x0"]
                elif e == "dead_zone":
                    params["width"] = P[e]
                elif e == "stiffness_nonlinearity":
                    params["k3"] = P[e]
                elif e == "sensor_offset":
                    off = g["out"](P[e] * (1.0 + drift_shape))
                    params["offset"] = float(np.mean(off))
                    span = float(g["t_sim"][-1] - g["t_sim"][0])
                    params["drift"] = float(P[e] * (drift_shape[-1] - drift_shape[0]) / span) if span > 0 else 0.0
                elif e == "time_delay":
                    params["delay"] = P[e]
                elif e == "vibration":
                    params["frequency"] = models["vibration_f"]
                    params["amplitude"] = P[e]
            model = {e: models[e] for e in effects if e in models}
            details = {}
            if hspec:
                details["hysteresis"] = {kk: vv for kk, vv in hspec.items() if kk != "model"}
            if "dead_zone" in effects and models["dead_zone"] == "smooth":
                details["dead_zone"] = {"eps": 0.2 * P["dead_zone"]}
            if "vibration" in effects:
                details["vibration"] = {"phase": vib_phase, "time_base": "real time from record start"}
            t_rec = g["t_rec"]
            n_rows = len(t_rec)
            if timing == "repeat3":
                dur_rec = 3 * float(g["exc_T"])
            elif timing == "bin20":
                dur_rec = n_rows / 20.0
            else:
                dur_rec = float(t_rec[-1] - t_rec[0]) + 1.0 / g["fs"]
            var = [s for s in (timing if timing != "plain" else None, enc if enc != "enc14" else None) if s]
            ans = {
                "effect": "+".join(effects) if effects else "none",
                "params": params,
                "noise": sigma,
                "fs": g["fs"],
                "variant": "-".join(var) if var else "plain",
                "effect_rms_over_noise": ratios,
                "model": model,
                "n_samples": int(n_rows),
                "duration": dur_rec,
                "timing": timing,
                "encoder": enc,
                "encoder_step": q,
                "noise_fraction_of_range": phi_act,
                "noise_sample_rms": rms(torque - full),
                "baseline": {"k": k, "k_a": ka, "k_b": kb},
                "amplitude": xmax,
                "freq_band": [f_lo, f_hi],
                "excitation": [s.info for s in exc.segs],
                "model_details": details,
                "seed": [int(seed), int(idx), int(attempt)],
            }
            if timing == "epoch":
                ans["t0_epoch"] = g["t0_epoch"]
            if timing == "jitter":
                ans["gaps"] = g["gaps"]
                ans["jitter_rms"] = g["jitter_rms"]
            if timing == "repeat3":
                ans["n_repetitions"] = 3
                ans["pause_between"] = g["pause"]
            if timing == "bin20":
                ans["bin"] = {"fine_rate": 1000.0, "bin_s": 0.05, "t": "mean time of the bin"}
            internal = None
            if want_internal:
                internal = {"R": R, "P": P, "full": full,
                            "contrib": {e: R.contrib(P, e) for e in effects}, "defl": defl}
            return t_rec, defl, torque, ans, internal
    raise RuntimeError(f"record {seed}/{idx} {effects} {timing}: no feasible draw")


def write_csv(path, t, defl, torque, timing, t0=None):
    if timing == "epoch":
        tt = np.char.mod("%.6f", t0 + t)
    else:
        tt = np.char.mod("%.7f", t)
    lines = np.char.add(np.char.add(np.char.add(tt, ","), np.char.mod("%.10g", defl)),
                        np.char.add(",", np.char.mod("%.7g", torque)))
    with open(path, "w") as fh:
        fh.write("t,deflection,torque\n")
        fh.write("\n".join(lines.tolist()))
        fh.write("\n")


def file_name(idx, effects, variant):
    eff = "+".join(effects) if effects else "clean"
    return f"{idx:03d}_{eff}_{variant}.csv"


def generate(out, seed):
    d = os.path.join(out, f"s{seed}")
    os.makedirs(d, exist_ok=True)
    answers = {}
    t_start = time.time()
    for idx, effects, timing, enc in plan(seed):
        t, defl, torque, ans, _ = build_record(seed, idx, effects, timing, enc)
        name = file_name(idx, effects, ans["variant"])
        write_csv(os.path.join(d, name), t, defl, torque, timing, ans.get("t0_epoch"))
        answers[name] = ans
        print(f"s{seed} {name:60s} n={ans['n_samples']:6d} ratios="
              f"{ {k: round(v, 2) for k, v in ans['effect_rms_over_noise'].items()} } "
              f"[{time.time() - t_start:.0f}s]", flush=True)
    with open(os.path.join(d, "answers.json"), "w") as fh:
        json.dump(answers, fh, indent=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, help="folder for s<seed>/ (about 100 MB a seed)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    a = ap.parse_args()
    for s in a.seeds:
        generate(a.out, s)


if __name__ == "__main__":
    main()
