#!/usr/bin/env python3
"""Rig-like characterisation records for `jointctl identify`.

Simulates (1) series-elastic-actuator stiffness-test rigs (torsion spring between a
position-controlled drive and a locked 6-axis torque sensor, deflection from a magnetic
linear encoder of 2e-6 rad steps, irregular ~550 Hz logging with epoch time stamps, several
drive amplitudes each repeated three times) and (2) collaborative-arm joint friction records
(link-side torque minus a gravity model, against joint position, 1 kHz, two motion cases at
three speeds).  Every device carries all the non-idealities of its kind at magnitudes drawn
per seed; the answers say which of them are visible and how they map onto the cause names.

Written blind: it shares no code or assumptions with the project it is meant to test.
See README.md next to this file for the models, ranges and reasons.

Usage:
    generate.py --out DIR --seeds 1 2 ...     # writes DIR/rig<seed>/*.csv + answers.json
    generate.py --check [--seed S] [--out DIR] # regenerate one seed in a temp dir and verify
"""

import argparse
import array
import hashlib
import json
import math
import os
import shutil
import sys
import tempfile
import time

import numpy as np
from scipy import signal

ENC_LSB = 2e-6            # rad, the rig encoder's step
FS_SIM = 2000.0           # Hz, rig simulation grid
FS_ARM = 1000.0           # Hz, arm controller rate
N_RIG_DEVICES = 4
N_ARM_DEVICES = 2
VOCAB = ("stiffness_nonlinearity", "hysteresis", "sensor_offset", "viscous_friction",
         "dead_zone", "time_delay", "vibration", "coulomb_friction", "stribeck_friction",
         "stiffness_error")
VISIBLE_FACTOR = 3.0      # a component counts as visible above this many noise floors
GENERATOR_VERSION = "rig_generator 1.0"


# ----------------------------------------------------------------------------- helpers

def lu(rng, a, b):
    """log-uniform draw"""
    return float(math.exp(rng.uniform(math.log(a), math.log(b))))


def un(rng, a, b):
    return float(rng.uniform(a, b))


def sgn(rng):
    return 1.0 if rng.random() < 0.5 else -1.0


def rms(x):
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x))) if x.size else 0.0


def file_entry(lst, below, shown, entry, note=""):
    """an answer's cause entry into `lst` when visible (`shown`), else into `below`, marked"""
    if note:
        entry["note"] = note
    if shown:
        lst.append(entry)
    else:
        entry["below_threshold"] = True
        below.append(entry)


def jsonable(o):
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, np.ndarray):
        return [jsonable(v) for v in o.tolist()]
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.bool_,)):
        return bool(o)
    if isinstance(o, float):
        if not math.isfinite(o):
            return None
        if abs(o) >= 1e5:
            return round(o, 6)
        return float(f"{o:.6g}") if o != 0 else 0.0
    return o


def lugre_step(z, v, fc, fs, vs, alpha, s0, dt):
    """exact LuGre bristle update for a constant velocity over one step (vector-free)"""
    av = abs(v)
    if av < 1e-12:
        return z
    g = fc + (fs - fc) * math.exp(-(av / vs) ** alpha)
    zss = g / s0 if v > 0 else -g / s0
    return zss + (z - zss) * math.exp(-s0 * av / g * dt)


def pink_noise(rng, n, fs, fmin=0.01):
    """approximately 1/f noise (unit variance) from AR(1) sources at octave-spaced corners"""
    fmax = fs / 2.0
    corners = []
    f = fmin
    while f < fmax:
        corners.append(f)
        f *= 2.0
    out = np.zeros(n)
    for fc in corners:
        a = math.exp(-2 * math.pi * fc / fs)
        w = rng.standard_normal(n) * math.sqrt(1 - a * a)
        y = signal.lfilter([1.0], [1.0, -a], w, zi=[a * rng.standard_normal()])[0]
        out += y
    out /= math.sqrt(len(corners))
    return out


def smooth_ramp(u, eps):
    return 0.5 * (u + np.sqrt(u * u + eps * eps))


# ----------------------------------------------------------------------------- rig device

def sample_rig_device(rng, name):
    elastomer = rng.random() < 0.25
    if elastomer:
        k0 = lu(rng, 120, 700)
        tau_max = un(rng, 8, 35)
    else:
        k0 = lu(rng, 250, 4000)
        tau_max = un(rng, 15, 75)
    dmax = tau_max / k0
    dev = {"name": name, "kind": "rig"}
    prog = {}
    for side in ("pos", "neg"):
        if rng.random() < 0.45:
            prog[side] = {"x_start": un(rng, 0.45, 0.9), "b": un(rng, 0.03, 0.25)}
    dev["spring"] = {
        "material": "elastomer (polyurethane) torsion element" if elastomer else "steel torsion spring",
        "k0_nm_per_rad": k0,
        "tau_max_nm": tau_max,
        "delta_max_rad": dmax,
        "a2": un(rng, -0.045, 0.045),
        "a3": un(rng, -0.08, 0.03) if elastomer else un(rng, -0.05, 0.07),
        "progressive": prog,
        "progressive_eps": 0.05,
        "kappa_T_per_K": un(rng, 3e-3, 8e-3) if elastomer else 2.6e-4,
        "k_datasheet_nm_per_rad": float(f"{k0 * (1 + 0.07 * rng.standard_normal()):.2g}"),
    }
    # Maxwell-slip (Iwan) hysteresis of the clamped/keyed interfaces and coil contacts
    ne = 10
    h_frac = un(rng, 0.01, 0.03) if elastomer else un(rng, 0.008, 0.045)
    H = h_frac * tau_max
    dlo = un(rng, 0.015, 0.08) * dmax
    dhi = un(rng, 0.25, 0.8) * dmax
    slips = np.exp(np.linspace(math.log(dlo), math.log(dhi), ne))
    w = rng.dirichlet(np.full(ne, 2.0))
    F = H * w
    dev["maxwell_slip"] = {
        "elements": ne, "limit_nm": H, "limit_frac_of_tau_max": h_frac,
        "slip_deflections_rad": slips.tolist(), "break_forces_nm": F.tolist(),
        "stiffnesses_nm_per_rad": (F / slips).tolist(),
        "initial_stiffness_nm_per_rad": float(np.sum(F / slips)),
        "prehistory_excursion_rad": sgn(rng) * un(rng, 0.3, 1.0) * dmax,
    }
    if elastomer:
        dev["viscoelastic"] = {"branches": [
            {"k_nm_per_rad": un(rng, 0.04, 0.15) * k0, "lambda_s": lu(rng, 0.03, 0.4)},
            {"k_nm_per_rad": un(rng, 0.03, 0.10) * k0, "lambda_s": lu(rng, 1.5, 15.0)}]}
    else:
        dev["viscoelastic"] = {"branches": []}
    if rng.random() < 0.3:
        wdz = un(rng, 0.003, 0.02) * dmax
        dev["clearance"] = {"half_width_rad": wdz, "contact_eps_rad": un(rng, 0.2, 0.6) * wdz,
                            "centre_rad": un(rng, -0.3, 0.3) * wdz}
    else:
        dev["clearance"] = None
    # drive
    N = int(rng.choice([50, 80, 100, 120, 160]))
    k_drive = lu(rng, 6e3, 4e4)
    f_m = un(rng, 18, 80)
    Jm = (k_drive + k0) / (2 * math.pi * f_m) ** 2
    zeta_m = un(rng, 0.02, 0.10)
    fcs = lu(rng, 0.2, 2.0)
    dev["drive"] = {
        "gear_ratio": N, "k_drive_nm_per_rad": k_drive, "mode_hz": f_m, "J_reflected": Jm,
        "zeta": zeta_m, "d_drive": 2 * zeta_m * math.sqrt((k_drive + k0) * Jm),
        "seal": {"Fc": fcs, "Fs": fcs * un(rng, 1.1, 1.6), "vs": lu(rng, 0.001, 0.008),
                 "alpha": un(rng, 0.8, 2.0), "z_ss": lu(rng, 5e-6, 3e-5), "sigma2": 0.0},
        "cogging_nm": lu(rng, 0.02, 0.3), "cogging_per_motor_rev": int(rng.choice([6, 8, 12, 18, 24])),
        "cogging_phase": un(rng, 0, 2 * math.pi),
        "kinematic_error_rad": [lu(rng, 2e-5, 1.2e-4)],
        "kin_phase": [un(rng, 0, 2 * math.pi), un(rng, 0, 2 * math.pi)],
        "motor_angle_offset_rad": un(rng, 0, 2 * math.pi),
        "rehome_sigma_rad": lu(rng, 0.001, 0.01) * dmax,
        "preload_rad": un(rng, -0.03, 0.03) * dmax,
    }
    dev["drive"]["kinematic_error_rad"].append(dev["drive"]["kinematic_error_rad"][0] * un(rng, 0.1, 0.5))
    # internal bearing of the spring module (parallel to the spring, fully seen)
    f_drive = un(rng, 0.12, 0.6)
    dd_ref = 2 * math.pi * f_drive * 0.75 * dmax
    fci = un(rng, 0.002, 0.012) * tau_max
    dev["internal_bearing"] = {
        "Fc": fci, "Fs": fci * un(rng, 1.1, 1.7), "vs": lu(rng, 0.0015, 0.012),
        "alpha": un(rng, 0.7, 2.0), "z_ss": lu(rng, 3e-6, 4e-5), "sigma1": lu(rng, 0.05, 0.5),
        "sigma2": un(rng, 0.05, 0.8) * fci / dd_ref, "load_coeff": un(rng, 0.0, 0.6),
        "visc_temp_coeff_per_K": un(rng, 0.01, 0.03),
    }
    # output shaft bearing/seal: in parallel with the sensor (bypass)
    fco = lu(rng, 0.05, 0.8)
    kf = lu(rng, 1e4, 1.5e5)
    f_o = lu(rng, 25, 150)
    Jo = float(np.clip((kf + k0) / (2 * math.pi * f_o) ** 2, 0.01, 0.6))
    f_o = math.sqrt((kf + k0) / Jo) / (2 * math.pi)
    zeta_o = un(rng, 0.008, 0.04)
    dev["output"] = {
        "k_fixture_nm_per_rad": kf, "mode_hz": f_o, "J_output": Jo, "zeta": zeta_o,
        "c_fixture": 2 * zeta_o * math.sqrt((kf + k0) * Jo),
        "bearing": {"Fc": fco, "Fs": fco * un(rng, 1.1, 1.6), "vs": lu(rng, 0.001, 0.01),
                    "alpha": un(rng, 0.8, 2.0), "z_ss": lu(rng, 2e-6, 2e-5), "sigma1": lu(rng, 0.02, 0.3)},
    }
    # torque sensor
    sw = lu(rng, 0.0018, 0.006)
    dev["sensor"] = {
        "gain": 1.0 + float(np.clip(0.008 * rng.standard_normal(), -0.02, 0.02)),
        "crosstalk": un(rng, 0.005, 0.03), "crosstalk_angle": un(rng, 0, 2 * math.pi),
        "lpf_hz": lu(rng, 150, 500), "fs_hz": float(rng.choice([1000.0, 1000.0, 2000.0, 7000.0])),
        "transport_s": lu(rng, 3e-4, 4e-3), "quantum_nm": lu(rng, 4e-4, 2.5e-3),
        "white_nm": sw, "pink_nm": sw * un(rng, 0.3, 1.0), "hum_nm": sw * un(rng, 0.0, 0.5),
        "hum_hz": 50.0 * (1 + 0.001 * rng.standard_normal()),
        "thermal_nm_per_K": sgn(rng) * lu(rng, 0.01, 0.08),
        "random_walk_nm_per_sqrt_s": lu(rng, 1e-4, 1e-3),
        "tare": "session_start" if rng.random() < 0.5 else "earlier",
        "earlier_zero_error_nm": sgn(rng) * un(rng, 0.003, 0.035) * tau_max,
    }
    # magnetic linear encoder across the spring
    R = un(rng, 0.05, 0.125)
    pitch_mm = float(rng.choice([1.0, 2.0]))
    sde1 = un(rng, 0.2, 1.2)
    dev["encoder"] = {
        "radius_m": R, "pole_pitch_mm": pitch_mm, "angular_pitch_rad": pitch_mm * 1e-3 / R,
        "sde_um": [sde1, sde1 * un(rng, 0.1, 0.5)], "sde_phase": [un(rng, 0, 2 * math.pi), un(rng, 0, 2 * math.pi)],
        "sde_rad": [sde1 * 1e-6 / R, 0.0],
        "hysteresis_um": un(rng, 0.2, 1.5), "noise_lsb": un(rng, 0.15, 0.6),
        "gain_error": float(np.clip(0.002 * rng.standard_normal(), -0.005, 0.005)),
        "zero": "per_repetition" if rng.random() < 0.5 else "session",
        "read_latency_s": lu(rng, 5e-5, 4e-4),
    }
    dev["encoder"]["sde_rad"][1] = dev["encoder"]["sde_um"][1] * 1e-6 / R
    dev["encoder"]["hysteresis_rad"] = dev["encoder"]["hysteresis_um"] * 1e-6 / R
    # thermal
    dev["thermal"] = {"ambient_C": un(rng, 20, 26), "rise_full_effort_K": un(rng, 1.5, 10),
                      "tau_s": lu(rng, 400, 2000), "ambient_drift_K_per_h": un(rng, -0.6, 0.6),
                      "initial_rise_frac": un(rng, 0, 0.3)}
    # logger
    dev["logger"] = {"dt_median_s": un(rng, 1.72e-3, 1.88e-3), "dt_sigma_log": un(rng, 0.04, 0.12),
                     "p_stall": un(rng, 0.017, 0.025), "stall_range_s": [5e-3, 45e-3],
                     "p_buffered": un(rng, 0.2, 0.7), "burst_spacing_s": lu(rng, 3e-5, 1.2e-4),
                     "gap_rate_per_s": 1.0 / un(rng, 40, 150), "gap_range_s": [0.04, 0.26],
                     "stamp_jitter_s": un(rng, 2e-5, 8e-5),
                     "epoch_start": un(rng, 1.69e9, 1.76e9)}
    # test programme
    fr = np.sort(np.array([0.15, 0.3, 0.5, 0.75, 1.0]) * (1 + rng.uniform(-0.05, 0.05, 5)))
    wave = "sine" if rng.random() < 0.5 else "triangle"
    dev["test"] = {
        "waveform": wave, "amplitudes_rad": (fr * dmax).tolist(),
        "timing": "constant_frequency" if (wave == "sine" or rng.random() < 0.5) else "constant_speed",
        "frequency_hz": f_drive, "peak_speed_rad_s": 4 * f_drive * 0.75 * dmax,
        "corner_s": lu(rng, 0.01, 0.15), "order": "blocked" if rng.random() < 0.6 else "interleaved",
        "reference_amplitude_index": int(rng.choice([2, 3, 4])),
        "one_amplitude_index": int(rng.choice([0, 1])),
        "rep1_index": int(rng.integers(0, 3)),
        "target_rep_s": un(rng, 9.0, 24.0),
        "amp_jitter": 0.003,
    }
    stability_guard(dev)
    return dev


def stability_guard(dev):
    """The explicit integrator needs every mass's stiffest path (including LuGre bristles in
    stick) below omega*dt = 1.  Raise a bristle's pre-sliding deflection z_ss where needed;
    the adjustment is recorded in the physics (z_ss_drawn)."""
    lim = (1.0 * FS_SIM) ** 2
    k0 = dev["spring"]["k0_nm_per_rad"]
    kh = dev["maxwell_slip"]["initial_stiffness_nm_per_rad"]
    kv = sum(b["k_nm_per_rad"] for b in dev["viscoelastic"]["branches"])
    o = dev["output"]
    d = dev["drive"]
    ib = dev["internal_bearing"]
    bud_o = o["J_output"] * lim - (o["k_fixture_nm_per_rad"] + k0 + kh + kv)
    bud_m = d["J_reflected"] * lim - (d["k_drive_nm_per_rad"] + k0 + kh + kv)
    assert bud_o > 0 and bud_m > 0, (bud_o, bud_m)
    for fr, cap in ((o["bearing"], 0.6 * bud_o), (d["seal"], 0.6 * bud_m), (ib, 0.35 * min(bud_o, bud_m))):
        zmin = fr["Fs"] / cap
        if fr["z_ss"] < zmin:
            fr["z_ss_drawn"] = fr["z_ss"]
            fr["z_ss"] = zmin


def plan_rig_session(rng, dev):
    test = dev["test"]
    amps = test["amplitudes_rad"]
    order = []
    if test["order"] == "blocked":
        for a in range(5):
            order += [(a, r) for r in range(3)]
    else:
        for r in range(3):
            order += [(a, r) for a in range(5)]
    reps = []
    for j, (a, r) in enumerate(order):
        A = amps[a] * (1 + test["amp_jitter"] * rng.standard_normal())
        if test["timing"] == "constant_frequency":
            f = test["frequency_hz"]
        else:
            f = min(1.5, test["peak_speed_rad_s"] / (4 * A))
        motion_target = test["target_rep_s"] * un(rng, 0.9, 1.1)
        ncyc = max(2, int(round(motion_target * f)))
        while ncyc / f > 34.0 and ncyc > 2:
            ncyc -= 1
        while ncyc / f < 8.0:
            ncyc += 1
        if j == 0:
            pause = 0.0
        else:
            prev_a = order[j - 1][0]
            pause = un(rng, 40, 400) if prev_a != a else un(rng, 4, 60)
        reps.append({"index": j, "amp_index": a, "rep": r, "amplitude_rad": A, "freq_hz": f,
                     "cycles": ncyc, "hold_pre_s": un(rng, 0.5, 1.5), "hold_post_s": un(rng, 0.5, 1.5),
                     "settle_s": 2.5 if j == 0 else 1.0, "pause_before_s": pause,
                     "centre_rad": dev["drive"]["preload_rad"] + dev["drive"]["rehome_sigma_rad"] * rng.standard_normal()})
    return reps


def rig_reference(dev, reps, fs):
    """Commanded drive-side angle (lumped drive input) on the simulation grid."""
    k0 = dev["spring"]["k0_nm_per_rad"]
    scale = 1 + k0 / dev["drive"]["k_drive_nm_per_rad"] + k0 / dev["output"]["k_fixture_nm_per_rad"]
    corner = dev["test"]["corner_s"]
    pieces, segs = [], []
    pos = 0
    prev_c = reps[0]["centre_rad"]
    for rp in reps:
        n_set = int(rp["settle_s"] * fs)
        n0 = int(rp["hold_pre_s"] * fs)
        nm = int(round(rp["cycles"] / rp["freq_hz"] * fs))
        n1 = int(rp["hold_post_s"] * fs)
        f = rp["freq_hz"]
        t = np.arange(nm) / fs
        if dev["test"]["waveform"] == "sine":
            y = np.sin(2 * np.pi * f * t)
            nr = max(2, int(0.5 / f * fs))
            env = np.ones(nm)
            ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(nr) / nr)
            env[:nr] = ramp
            env[-nr:] = ramp[::-1]
            y = y * env
            core = np.concatenate([np.zeros(n0), y, np.zeros(n1)])
        else:
            y = 2 / np.pi * np.arcsin(np.sin(2 * np.pi * f * t))
            core = np.concatenate([np.zeros(n0), y, np.zeros(n1)])
            nc = max(3, int(corner * fs))
            box = np.ones(nc) / nc
            core = np.convolve(core, box, mode="same") / max(1e-9, 1 - f * corner)
        c = rp["centre_rad"]
        # homing from the previous centre during the unlogged settle
        nh = min(n_set // 2, int(0.5 * fs))
        settle = np.full(n_set, c)
        settle[:nh] = prev_c + (c - prev_c) * (0.5 - 0.5 * np.cos(np.pi * np.arange(nh) / nh))
        th = np.concatenate([settle, c + scale * rp["amplitude_rad"] * core])
        pieces.append(th)
        segs.append({"start": pos, "log_start": pos + n_set, "end": pos + len(th),
                     "motion_start": pos + n_set + n0, "motion_end": pos + n_set + n0 + nm})
        pos += len(th)
        prev_c = c
    thc = np.concatenate(pieces)
    dr = dev["drive"]
    N = dr["gear_ratio"]
    ang = thc + dr["motor_angle_offset_rad"]
    e1, e2 = dr["kinematic_error_rad"]
    p1, p2 = dr["kin_phase"]
    thc = thc + e1 * np.sin(2 * N * ang + p1) + e2 * np.sin(N * ang + p2)
    vc = np.gradient(thc) * fs
    return thc, vc, segs


def rig_wall_layout(dev, reps, segs, fs):
    """wall-clock offset (s) to add to sim time, per rep; and the thermal history"""
    W0 = dev["logger"]["epoch_start"]
    offs = []
    acc = 0.0
    for rp in reps:
        acc += rp["pause_before_s"]
        offs.append(acc)
    # thermal: coarse grid over wall time
    th = dev["thermal"]
    dmax = dev["spring"]["delta_max_rad"]
    t_end_sim = segs[-1]["end"] / fs
    wall_end = t_end_sim + offs[-1] + 1.0
    h = 0.5
    tw = np.arange(0.0, wall_end + h, h)
    effort = np.zeros_like(tw)
    for rp, sg, o in zip(reps, segs, offs):
        a = sg["motion_start"] / fs + o
        b = sg["motion_end"] / fs + o
        effort[(tw >= a) & (tw < b)] = (rp["amplitude_rad"] / dmax) ** 2
    al = math.exp(-h / th["tau_s"])
    rise = signal.lfilter([th["rise_full_effort_K"] * (1 - al)], [1, -al], effort,
                          zi=[al * th["initial_rise_frac"] * th["rise_full_effort_K"]])[0]
    temp = th["ambient_C"] + th["ambient_drift_K_per_h"] * tw / 3600.0 + rise
    return W0, np.array(offs), tw, temp


def simulate_rig(dev, thc, vc, sT, bT, dt):
    """Lumped 2-DOF rig: drive-side inertia on the drive stiffness, the spring path
    (elastic + Maxwell-slip + viscoelastic + internal-bearing LuGre), the output flange on
    the sensor/fixture compliance with the output-bearing LuGre in parallel, the drive-side
    seal LuGre and cogging.  Symplectic Euler; exact exponential LuGre bristle updates."""
    n = len(thc)
    sp = dev["spring"]
    k0 = sp["k0_nm_per_rad"]
    dr_ = sp["delta_max_rad"]
    inv_dr = 1.0 / dr_
    kdr = k0 * dr_
    a2 = sp["a2"]
    a3 = sp["a3"]
    pp = sp["progressive"].get("pos")
    pn = sp["progressive"].get("neg")
    has_pp = pp is not None
    has_pn = pn is not None
    xp, bp = (pp["x_start"], pp["b"]) if has_pp else (9.0, 0.0)
    xn, bn = (pn["x_start"], pn["b"]) if has_pn else (9.0, 0.0)
    pe = sp["progressive_eps"]
    pe2 = pe * pe
    ms = dev["maxwell_slip"]
    D = list(ms["slip_deflections_rad"])
    K = list(ms["stiffnesses_nm_per_rad"])
    NE = len(D)
    # pre-history: 0 -> excursion -> start position (Masing rule state)
    p = [0.0] * NE
    start_d = (thc[0]) / (1 + k0 / dev["drive"]["k_drive_nm_per_rad"] + k0 / dev["output"]["k_fixture_nm_per_rad"])
    for target in (ms["prehistory_excursion_rad"], start_d):
        for j in range(NE):
            s = target - p[j]
            if s > D[j]:
                p[j] = target - D[j]
            elif s < -D[j]:
                p[j] = target + D[j]
    ve = dev["viscoelastic"]["branches"]
    NB = len(ve)
    kv = [b["k_nm_per_rad"] for b in ve]
    Ev = [math.exp(-dt / b["lambda_s"]) for b in ve]
    Gv = [b["k_nm_per_rad"] * b["lambda_s"] * (1 - math.exp(-dt / b["lambda_s"])) / dt for b in ve]
    qv = [0.0] * NB
    cl = dev["clearance"]
    has_cl = cl is not None
    if has_cl:
        cw = cl["half_width_rad"]
        ce2 = cl["contact_eps_rad"] ** 2
        cc = cl["centre_rad"]
    else:
        cw = ce2 = cc = 0.0
    ib = dev["internal_bearing"]
    i_fc, i_fs, i_vs, i_al = ib["Fc"], ib["Fs"], ib["vs"], ib["alpha"]
    i_s0 = ib["Fs"] / ib["z_ss"]
    i_s1 = ib["sigma1"]
    i_lc = ib["load_coeff"] / sp["tau_max_nm"]
    ob = dev["output"]["bearing"]
    o_fc, o_fs, o_vs, o_al = ob["Fc"], ob["Fs"], ob["vs"], ob["alpha"]
    o_s0 = ob["Fs"] / ob["z_ss"]
    o_s1 = ob["sigma1"]
    dv = dev["drive"]
    sl = dv["seal"]
    s_fc, s_fs, s_vs, s_al = sl["Fc"], sl["Fs"], sl["vs"], sl["alpha"]
    s_s0 = sl["Fs"] / sl["z_ss"]
    s_s1 = 0.3 * math.sqrt(s_s0 * dv["J_reflected"])
    kd = dv["k_drive_nm_per_rad"]
    cd = dv["d_drive"]
    invJm = 1.0 / dv["J_reflected"]
    cog = dv["cogging_nm"]
    ncog = dv["gear_ratio"] * dv["cogging_per_motor_rev"]
    pcog = dv["cogging_phase"] + ncog * dv["motor_angle_offset_rad"]
    out = dev["output"]
    kf = out["k_fixture_nm_per_rad"]
    cf = out["c_fixture"]
    Jo = out["J_output"]
    invJo = 1.0 / Jo
    exp = math.exp
    sqrt = math.sqrt
    sin = math.sin

    names = ("d", "dd", "ds", "tel", "tms", "tve", "tfi", "tbo", "tin", "tst", "thm")
    arrs = {k: array.array("d", bytes(8 * n)) for k in names}
    A_d, A_dd, A_ds, A_tel, A_tms, A_tve, A_tfi, A_tbo, A_tin, A_tst, A_thm = (arrs[k] for k in names)
    thcl = thc.tolist()
    vcl = vc.tolist()
    sTl = sT.tolist()
    bTl = bT.tolist()

    # start near static equilibrium
    tau0 = k0 * start_d
    tho = tau0 / kf
    thm = tho + start_d
    wm = wo = 0.0
    zi = zo = zs = 0.0
    ds_prev = start_d - cc if not has_cl else 0.0
    first = True
    for i in range(n):
        d = thm - tho
        dd = wm - wo
        if has_cl:
            u = d - cc
            um = u - cw
            up = u + cw
            ds = 0.5 * (um + sqrt(um * um + ce2)) + 0.5 * (up - sqrt(up * up + ce2))
        else:
            ds = d
        if first:
            ds_prev = ds
            first = False
        x = ds * inv_dr
        poly = x + a2 * x * x + a3 * x * x * x
        if has_pp:
            r = x - xp
            r = 0.5 * (r + sqrt(r * r + pe2))
            poly += bp * r * r
        if has_pn:
            r = -x - xn
            r = 0.5 * (r + sqrt(r * r + pe2))
            poly -= bn * r * r
        tel = sTl[i] * kdr * poly
        tms = 0.0
        for j in range(NE):
            s = ds - p[j]
            Dj = D[j]
            if s > Dj:
                p[j] = ds - Dj
                s = Dj
            elif s < -Dj:
                p[j] = ds + Dj
                s = -Dj
            tms += K[j] * s
        tve = 0.0
        if NB:
            dds = ds - ds_prev
            for b in range(NB):
                qv[b] = qv[b] * Ev[b] + Gv[b] * dds
                tve += qv[b]
        ds_prev = ds
        # internal bearing (parallel to the spring): lugre_step's update with the levels scaled
        # by the load, written out so that the scaling stays where the records were made with it
        av = dd if dd >= 0 else -dd
        if av > 1e-12:
            lf = 1.0 + i_lc * (tel if tel >= 0 else -tel)
            g = lf * (i_fc + (i_fs - i_fc) * exp(-(av / i_vs) ** i_al))
            zss = g / i_s0 if dd > 0 else -g / i_s0
            zn = zss + (zi - zss) * exp(-i_s0 * av / g * dt)
        else:
            zn = zi
        tfi = i_s0 * zn + i_s1 * (zn - zi) / dt + bTl[i] * dd
        zi = zn
        # output bearing (parallel to the sensor)
        zn = lugre_step(zo, wo, o_fc, o_fs, o_vs, o_al, o_s0, dt)
        tbo = o_s0 * zn + o_s1 * (zn - zo) / dt
        zo = zn
        # drive-side seal
        zn = lugre_step(zs, wm, s_fc, s_fs, s_vs, s_al, s_s0, dt)
        tse = s_s0 * zn + s_s1 * (zn - zs) / dt
        zs = zn
        tpath = tel + tms + tve + tfi
        tst = kf * tho + cf * wo
        am = (kd * (thcl[i] - thm) + cd * (vcl[i] - wm) - tpath - tse + cog * sin(ncog * thm + pcog)) * invJm
        ao = (tpath - tst - tbo) * invJo
        A_d[i] = d
        A_dd[i] = dd
        A_ds[i] = ds
        A_tel[i] = tel
        A_tms[i] = tms
        A_tve[i] = tve
        A_tfi[i] = tfi
        A_tbo[i] = tbo
        A_tin[i] = Jo * ao
        A_tst[i] = tst
        A_thm[i] = thm
        wm += dt * am
        thm += dt * wm
        wo += dt * ao
        tho += dt * wo
    return {k: np.frombuffer(v, dtype=float).copy() for k, v in arrs.items()}


def spring_f0(dev, x_rad):
    """elastic characteristic at reference temperature (vectorised)"""
    sp = dev["spring"]
    k0 = sp["k0_nm_per_rad"]
    dr_ = sp["delta_max_rad"]
    x = np.asarray(x_rad) / dr_
    poly = x + sp["a2"] * x * x + sp["a3"] * x ** 3
    pe = sp["progressive_eps"]
    if "pos" in sp["progressive"]:
        pp = sp["progressive"]["pos"]
        poly = poly + pp["b"] * smooth_ramp(x - pp["x_start"], pe) ** 2
    if "neg" in sp["progressive"]:
        pn = sp["progressive"]["neg"]
        poly = poly - pn["b"] * smooth_ramp(-x - pn["x_start"], pe) ** 2
    return k0 * dr_ * poly


def play_operator(x, half):
    out = array.array("d", bytes(8 * len(x)))
    y = float(x[0])
    for i, v in enumerate(x.tolist()):
        if v - y > half:
            y = v - half
        elif y - v > half:
            y = v + half
        out[i] = y
    return np.frombuffer(out, dtype=float).copy()


def log_times(rng, L, t0, t1):
    """true read times and logger stamps (sim-time base) for one repetition"""
    dtm = L["dt_median_s"]
    est = int((t1 - t0) / dtm * 1.05) + 200
    dts = dtm * np.exp(L["dt_sigma_log"] * rng.standard_normal(est))
    stall = rng.random(est) < L["p_stall"]
    lo, hi = L["stall_range_s"]
    slen = np.exp(rng.uniform(math.log(lo), math.log(hi), est))
    buffered = stall & (rng.random(est) < L["p_buffered"])
    dropped = stall & ~buffered
    dts = np.where(dropped, slen, dts)
    t_true = t0 + np.concatenate([[0.0], np.cumsum(dts[:-1])])
    # long gaps (dropped), Poisson in time
    ng = rng.poisson(L["gap_rate_per_s"] * (t1 - t0))
    for _ in range(ng):
        tg = rng.uniform(t0 + 0.5, max(t0 + 0.6, t1 - 0.5))
        glen = lu(rng, *L["gap_range_s"])
        t_true = np.where(t_true > tg, t_true + glen, t_true)
    t_true = t_true[t_true < t1]
    stamps = t_true + np.abs(L["stamp_jitter_s"] * rng.standard_normal(len(t_true)))
    # buffered stalls: samples keep being read on time, but are stamped when the logger wakes
    bidx = np.nonzero(buffered[:len(t_true)])[0]
    for b in bidx:
        ts = t_true[b]
        te = ts + slen[b]
        j = b + 1
        k = 0
        while j < len(t_true) and t_true[j] < te:
            stamps[j] = te + k * L["burst_spacing_s"]
            j += 1
            k += 1
    # strictly increasing stamps with >= 10 us spacing
    eps = 1e-5
    idx = np.arange(len(stamps)) * eps
    stamps = np.maximum.accumulate(stamps - idx) + idx
    return t_true, stamps


def rig_session(seed, dev_index):
    rng = np.random.default_rng([seed, 1000 + dev_index, 17])
    name = f"d{dev_index + 1}"
    dev = sample_rig_device(rng, name)
    reps = plan_rig_session(rng, dev)
    fs = FS_SIM
    dt = 1.0 / fs
    thc, vc, segs = rig_reference(dev, reps, fs)
    n = len(thc)
    tsim = np.arange(n) * dt
    W0, offs, tw, temp = rig_wall_layout(dev, reps, segs, fs)
    # wall time of every sim sample
    rep_of_sim = np.zeros(n, dtype=int)
    for j, sg in enumerate(segs):
        rep_of_sim[sg["start"]:sg["end"]] = j
    wall_sim = tsim + offs[rep_of_sim]
    T_sim = np.interp(wall_sim, tw, temp)
    T_ref = dev["thermal"]["ambient_C"]
    sT = 1.0 - dev["spring"]["kappa_T_per_K"] * (T_sim - T_ref)
    bT = dev["internal_bearing"]["sigma2"] * np.exp(-dev["internal_bearing"]["visc_temp_coeff_per_K"] * (T_sim - T_ref))
    S = simulate_rig(dev, thc, vc, sT, bT, dt)
    # ---- encoder reading on the sim grid (scale error is periodic in the scale position)
    en = dev["encoder"]
    P = en["angular_pitch_rad"]
    r = (1 + en["gain_error"]) * S["d"] + en["sde_rad"][0] * np.sin(2 * np.pi * S["d"] / P + en["sde_phase"][0]) \
        + en["sde_rad"][1] * np.sin(4 * np.pi * S["d"] / P + en["sde_phase"][1])
    r_h = play_operator(r, 0.5 * en["hysteresis_rad"])
    # ---- sensor chain on the sim grid
    se = dev["sensor"]
    ang = S["thm"] + dev["drive"]["motor_angle_offset_rad"] + se["crosstalk_angle"]
    xt_sim = se["crosstalk"] * S["tst"] * np.sin(ang) - se["crosstalk"] * S["tst"] * math.sin(
        dev["drive"]["motor_angle_offset_rad"] + se["crosstalk_angle"])  # calibrated at zero angle
    y_sim = se["gain"] * S["tst"] + xt_sim
    b, a = signal.butter(2, se["lpf_hz"] / (fs / 2))
    yf_sim = signal.lfilter(b, a, y_sim, zi=signal.lfilter_zi(b, a) * y_sim[0])[0]
    # sensor sample clock (continuous in sim time), noise per sensor sample
    fss = se["fs_hz"]
    phs = rng.uniform(0, 1 / fss)
    nsens = int(tsim[-1] * fss) + 2
    tk = phs + np.arange(nsens) / fss
    white_k = se["white_nm"] * rng.standard_normal(nsens)
    pink_k = se["pink_nm"] * pink_noise(rng, nsens, fss)
    hum_ph = rng.uniform(0, 2 * np.pi)
    # offset drift: thermal + random walk on the wall-time grid
    rw = np.concatenate([[0.0], np.cumsum(rng.standard_normal(len(tw) - 1))]) * se["random_walk_nm_per_sqrt_s"] * math.sqrt(tw[1] - tw[0])
    o_raw_w = se["thermal_nm_per_K"] * (temp - T_ref) + rw
    t_tare = 0.8
    o_raw_tare = float(np.interp(t_tare + offs[0], tw, o_raw_w))
    if se["tare"] == "session_start":
        bias_extra = float(np.interp(t_tare, tsim, yf_sim))
    else:
        bias_extra = -se["earlier_zero_error_nm"]
    # ---- log samples per repetition
    L = dev["logger"]
    rows = []
    for j, (rp, sg) in enumerate(zip(reps, segs)):
        t0 = sg["log_start"] * dt
        t1 = (sg["end"] - 1) * dt
        t_true, stamps = log_times(rng, L, t0, t1)
        rows.append((j, t_true, stamps))
    t_true = np.concatenate([r_[1] for r_ in rows])
    stamps_sim = np.concatenate([r_[2] for r_ in rows])
    rep_id = np.concatenate([np.full(len(r_[1]), r_[0]) for r_ in rows])
    wall = W0 + stamps_sim + offs[rep_id]
    te = t_true - en["read_latency_s"]
    I = lambda arr_: np.interp(te, tsim, arr_)
    d_true = I(S["d"])
    rh = I(r_h)
    counts = np.rint((rh + en["noise_lsb"] * ENC_LSB * rng.standard_normal(len(te))) / ENC_LSB).astype(np.int64)
    # zeroing
    first_rows = np.array([np.nonzero(rep_id == j)[0][0] for j in range(len(reps))])
    if en["zero"] == "session":
        zrow = np.full(len(reps), first_rows[0])
    else:
        zrow = first_rows
    czero = counts[zrow[rep_id]]
    dzero = d_true[zrow[rep_id]]
    dmeas = (counts - czero) * ENC_LSB
    x = d_true - dzero
    # torque path components at the encoder time
    k0 = dev["spring"]["k0_nm_per_rad"]
    sTi = I(sT)
    f0x = spring_f0(dev, x)
    f_x = sTi * f0x
    f_true = sTi * spring_f0(dev, d_true)
    f_act = I(S["tel"])  # the elastic torque the simulation used (interpolated like the rest)
    tfi = I(S["tfi"])
    dd_true = I(S["dd"])
    fi_visc = I(bT) * dd_true
    tst = I(S["tst"])
    comp = {
        "linear": k0 * dmeas,
        "encoder": k0 * (x - dmeas),
        "thermal_stiffness": (sTi - 1) * k0 * x,
        "nonlinearity": sTi * (f0x - k0 * x),
        "zero_shift": f_true - f_x,
        "clearance": f_act - f_true,
        "hysteresis": I(S["tms"]),
        "viscoelastic": I(S["tve"]),
        "friction_visc": fi_visc,
        "friction_dry": tfi - fi_visc,
        "bypass": -I(S["tbo"]),
        "inertial": -I(S["tin"]),
    }
    chk = sum(comp.values()) - tst
    assert np.max(np.abs(chk)) < 1e-6 * (1 + np.max(np.abs(tst))), np.max(np.abs(chk))
    # sensor chain at the logger
    kidx = np.floor((t_true - se["transport_s"] - phs) * fss).astype(np.int64)
    kidx = np.clip(kidx, 0, nsens - 1)
    tks = tk[kidx]
    chain = np.interp(tks, tsim, yf_sim)
    comp["gain"] = (se["gain"] - 1) * tst
    comp["crosstalk"] = I(xt_sim)
    comp["sensor_dynamics"] = chain - (tst + comp["gain"] + comp["crosstalk"])
    o_raw = np.interp(wall - W0, tw, o_raw_w)
    comp["offset_drift"] = o_raw - o_raw_tare - bias_extra
    comp["white"] = white_k[kidx]
    comp["pink"] = pink_k[kidx]
    comp["hum"] = se["hum_nm"] * math.sqrt(2) * np.sin(2 * np.pi * se["hum_hz"] * (tks + offs[rep_id]) + hum_ph)
    pre = sum(comp.values())
    q = se["quantum_nm"]
    tmeas = np.rint(pre / q) * q
    comp["quantisation"] = tmeas - pre
    # the split of internal friction for the answers
    ib = dev["internal_bearing"]
    lf = 1 + ib["load_coeff"] / dev["spring"]["tau_max_nm"] * np.abs(f_act)
    gv = lf * (ib["Fc"] + (ib["Fs"] - ib["Fc"]) * np.exp(-(np.abs(dd_true) / ib["vs"]) ** ib["alpha"]))
    strib_frac = np.clip((gv - lf * ib["Fc"]) / np.maximum(gv, 1e-12), 0, 1)
    comp["friction_stribeck"] = comp["friction_dry"] * strib_frac
    comp["friction_coulomb"] = comp["friction_dry"] - comp["friction_stribeck"]
    del comp["friction_dry"]
    sess = {
        "dev": dev, "reps": reps, "segs": segs, "offs": offs, "W0": W0,
        "wall": wall, "rep_id": rep_id, "dmeas": dmeas, "counts": counts, "tmeas": tmeas,
        "comp": comp, "dd_true": dd_true, "d_true": d_true, "x": x, "temp_C": np.interp(wall - W0, tw, temp),
        "delay_s": se["transport_s"] + 0.5 / fss + math.sqrt(2) / (2 * math.pi * se["lpf_hz"]) - en["read_latency_s"],
        "sim_inertial": S["tin"], "fs_sim": fs,
    }
    return sess


# ----------------------------------------------------------------------------- analysis

def atan_reg(dd, kb):
    return np.arctan(kb * dd)


def fit_baseline(d, tau, dd, grid=None):
    """linear spring + ka*atan(kb*ddot) (no offset); returns rms, coef, kb"""
    vpk = np.percentile(np.abs(dd), 95) + 1e-12
    if grid is None:
        grid = np.exp(np.linspace(math.log(0.3), math.log(3000), 24)) / vpk
    best = None
    for kb in grid:
        X = np.column_stack([d, atan_reg(dd, kb)])
        c, *_ = np.linalg.lstsq(X, tau, rcond=None)
        r = rms(tau - X @ c)
        if best is None or r < best[0]:
            best = (r, c, kb)
    return best


def dahl_shape(d, lam):
    dd = np.diff(d, prepend=d[0])
    e = np.exp(-lam * np.abs(dd)).tolist()
    s = np.sign(dd).tolist()
    out = array.array("d", bytes(8 * len(d)))
    z = 0.0
    for i in range(len(d)):
        si = s[i]
        if si != 0.0:
            z = si + (z - si) * e[i]
        out[i] = z
    return np.frombuffer(out, dtype=float).copy()


def fit_offset_cubic_dahl(d, tau, dd, kb):
    amp = np.percentile(np.abs(d - np.median(d)), 98) + 1e-12
    best = None
    base = np.column_stack([np.ones_like(d), d, d ** 3, atan_reg(dd, kb)])
    for lam_amp in np.exp(np.linspace(math.log(2), math.log(600), 12)):
        z = dahl_shape(d, lam_amp / amp)
        X = np.column_stack([base, z])
        c, *_ = np.linalg.lstsq(X, tau, rcond=None)
        r = rms(tau - X @ c)
        if best is None or r < best[0]:
            best = (r, c, lam_amp / amp)
    return best


def visible(e, X):
    c, *_ = np.linalg.lstsq(X, e, rcond=None)
    return rms(e - X @ c)


def finish_causes(expected, ambiguous, below, base_rms):
    """strongest first; each with its share of the baseline's residual"""
    for lst in (expected, ambiguous, below):
        for e in lst:
            e["share_of_baseline_residual"] = e["visible_rms_nm"] / max(base_rms, 1e-12)
        lst.sort(key=lambda e: -e["visible_rms_nm"])


def per_rep_mean(v, rep_local):
    return [float(np.mean(v[rep_local == r])) for r in np.unique(rep_local)]


def demean_per_rep(v, rep_local):
    out = v.copy()
    for r in np.unique(rep_local):
        m = rep_local == r
        out[m] -= out[m].mean()
    return out


def time_stats(t, rep_local):
    dts = []
    for r in np.unique(rep_local):
        tt = t[rep_local == r]
        if len(tt) > 1:
            dts.append(np.diff(tt))
    dts = np.concatenate(dts) if dts else np.array([0.0])
    return {"median_dt_ms": float(np.median(dts) * 1e3), "p99_dt_ms": float(np.percentile(dts, 99) * 1e3),
            "max_dt_within_repetition_s": float(dts.max()), "mean_rate_hz": float(1.0 / dts.mean()),
            "gaps_over_0.1s": int(np.sum(dts > 0.1))}


# ----------------------------------------------------------------------------- rig files

RIG_COMPONENT_DOC = {
    "encoder": "encoder errors in torque units k0*(true-zeroed deflection - logged deflection): scale interpolation error periodic in the pole pitch, reading hysteresis, flicker, 2e-6 rad quantisation, radius (gain) error",
    "thermal_stiffness": "stiffness change with temperature",
    "nonlinearity": "spring characteristic minus its tangent at zero (quadratic asymmetry, cubic, progressive contact)",
    "zero_shift": "spring preload/residual deflection hidden by zeroing the encoder",
    "clearance": "keyed-hub clearance inside the encoder span (backlash; a dead zone in the torque-deflection plane)",
    "hysteresis": "Maxwell-slip (Iwan) rate-independent hysteresis",
    "viscoelastic": "elastomer relaxation branches (rate-dependent)",
    "friction_visc": "internal-bearing viscous part",
    "friction_coulomb": "internal-bearing LuGre friction at the Coulomb level (incl. pre-sliding and load dependence)",
    "friction_stribeck": "internal-bearing friction above the Coulomb level (Stribeck)",
    "bypass": "output-bearing friction in parallel with the torque sensor (mostly pre-sliding)",
    "inertial": "output flange inertia on the fixture compliance (lightly damped rig resonance)",
    "gain": "torque sensor calibration gain error",
    "crosstalk": "6-axis crosstalk of the spring's radial reaction, rotating with the drive angle",
    "sensor_dynamics": "sensor low-pass, sample-and-hold and transport latency relative to the encoder",
    "offset_drift": "sensor zero: tare residue/earlier zero error + thermal drift + random walk",
    "white": "white torque noise",
    "pink": "1/f torque noise",
    "hum": "50 Hz mains pickup",
    "quantisation": "torque output quantum",
}


def bin20(wall, rep_id, cols):
    """means over 50 ms bins aligned to the epoch; bins never cross repetitions"""
    key = np.floor(wall / 0.05).astype(np.int64) * 100 + rep_id  # rep_id < 100
    starts = np.concatenate([[0], np.nonzero(np.diff(key) != 0)[0] + 1])
    cnt = np.diff(np.concatenate([starts, [len(key)]]))
    out = {k: np.add.reduceat(v, starts) / cnt for k, v in cols.items()}
    tb = (np.floor(wall[starts] / 0.05) + 0.5) * 0.05
    return tb, rep_id[starts], out, cnt


def rig_file_answers(sess, variant, mask, binned=False):
    dev = sess["dev"]
    reps = sess["reps"]
    rep_id = sess["rep_id"][mask]
    wall = sess["wall"][mask]
    comp = {k: v[mask] for k, v in sess["comp"].items()}
    dmeas = sess["dmeas"][mask]
    tmeas = sess["tmeas"][mask]
    dd = sess["dd_true"][mask]
    nper = None
    if binned:
        cols = dict(comp)
        cols["_d"] = dmeas
        cols["_t"] = tmeas
        cols["_dd"] = dd
        wall, rep_id, cols, nper = bin20(wall, rep_id, cols)
        dmeas = cols.pop("_d")
        tmeas = cols.pop("_t")
        dd = cols.pop("_dd")
        comp = cols
    k0 = dev["spring"]["k0_nm_per_rad"]
    uniq = list(dict.fromkeys(rep_id.tolist()))
    rep_local = np.array([uniq.index(r) for r in rep_id.tolist()])
    # noise
    white = comp["white"]
    coloured = demean_per_rep(comp["pink"], rep_local)
    floor_series = white + coloured + comp["hum"] + comp["quantisation"]
    noise_white = rms(white)
    noise_floor = rms(floor_series)
    # fits
    r0, c0, kb = fit_baseline(dmeas, tmeas, dd)
    X = np.column_stack([dmeas, atan_reg(dd, kb)])
    vis = {k: visible(v, X) for k, v in comp.items() if k != "linear"}
    raw = {k: rms(v) for k, v in comp.items() if k != "linear"}
    diag = {"baseline_linear_plus_arctan_rms_nm": r0, "baseline_k_nm_per_rad": float(c0[0]),
            "baseline_ka_nm": float(c0[1]), "baseline_kb_s_per_rad": float(kb),
            "note": "fits made by this generator with the true deflection rate in the arctan; for orientation only"}
    if variant != "amp5":
        r1, c1, lam = fit_offset_cubic_dahl(dmeas, tmeas, dd, kb)
        diag["offset_cubic_dahl_rms_nm"] = r1
        diag["offset_cubic_dahl_params"] = {"offset_nm": float(c1[0]), "k_nm_per_rad": float(c1[1]),
                                            "k3_nm_per_rad3": float(c1[2]), "ka_nm": float(c1[3]),
                                            "dahl_limit_nm": float(c1[4]), "dahl_sigma_over_limit_per_rad": float(lam)}
    thr = VISIBLE_FACTOR * noise_floor
    # amplitude of this file
    amps_in = sorted(set(reps[r]["amp_index"] for r in uniq))
    dspan = float(np.percentile(dmeas, 99.5) - np.percentile(dmeas, 0.5))
    dmid = float(0.5 * (np.percentile(dmeas, 99.5) + np.percentile(dmeas, 0.5)))
    # dominant frequency of the inertial torque during this file's motion (simulation grid)
    pieces = []
    for r in uniq:
        sg = sess["segs"][r]
        seg = sess["sim_inertial"][sg["motion_start"]:sg["motion_end"]]
        pieces.append(seg - seg.mean())
    xin = np.concatenate(pieces)
    fw, pw = signal.welch(xin, fs=sess["fs_sim"], nperseg=min(8192, len(xin)))
    sel = fw > 5.0
    vib_peak_hz = float(fw[sel][np.argmax(pw[sel])])
    # --- map onto the vocabulary
    expected, ambiguous, nov, below = [], [], [], []

    def add(lst, cause, vis_key, params, model, note=""):
        v = visible(sum(comp[k] for k in vis_key), X) if isinstance(vis_key, (list, tuple)) else vis[vis_key]
        file_entry(lst, below, v >= thr, {"cause": cause, "params": params, "model": model, "visible_rms_nm": v}, note)

    # stiffness nonlinearity: LS cubic/quadratic of the nonlinearity component in logged coordinates
    nl = comp["nonlinearity"] + comp["zero_shift"] - np.mean(comp["zero_shift"])
    Xn = np.column_stack([dmeas, dmeas ** 2, dmeas ** 3])
    cn, *_ = np.linalg.lstsq(Xn, nl, rcond=None)
    sp = dev["spring"]
    add(expected, "stiffness_nonlinearity", "nonlinearity",
        {"k3_nm_per_rad3": float(cn[2]), "k2_nm_per_rad2": float(cn[1]),
         "rel_stiffness_change_at_amplitude": [float((cn[1] * 2 * a + 3 * cn[2] * a * a) / k0) for a in (-0.5 * dspan, 0.5 * dspan)]},
        "polynomial (a2, a3) plus smooth progressive contact per side: " + json.dumps(jsonable({"a2": sp["a2"], "a3": sp["a3"], "progressive": sp["progressive"]})),
        "k3 is the least-squares cubic over this file's deflection range; the quadratic (asymmetric) part and the progressive contact are not a cubic")
    # hysteresis
    hy = comp["hysteresis"]
    ms = dev["maxwell_slip"]
    amp_here = 0.5 * dspan
    slipping = float(np.sum(np.array(ms["break_forces_nm"])[np.array(ms["slip_deflections_rad"]) < 2 * amp_here]))
    add(expected, "hysteresis", "hysteresis",
        {"limit_nm": ms["limit_nm"], "loop_half_height_nm": float(0.5 * (np.percentile(hy, 99) - np.percentile(hy, 1))),
         "force_of_elements_that_slip_at_this_amplitude_nm": slipping,
         "initial_stiffness_nm_per_rad": ms["initial_stiffness_nm_per_rad"]},
        "Maxwell-slip (Iwan) with %d elements, slip deflections %.3g-%.3g rad (Masing minor loops)" % (
            ms["elements"], ms["slip_deflections_rad"][0], ms["slip_deflections_rad"][-1]),
        "rate-independent; minor loops at small amplitude are narrower and stiffer than a Dahl state with the major-loop parameters")
    # offset
    off = comp["offset_drift"] + comp["zero_shift"]
    per = per_rep_mean(off, rep_local)
    add(expected, "sensor_offset", ["offset_drift", "zero_shift"],
        {"offset_nm": float(np.mean(off)), "per_repetition_nm": per,
         "drift_within_file_nm": float(np.percentile(comp["offset_drift"], 99) - np.percentile(comp["offset_drift"], 1))},
        "apparent loop-centre offset: sensor tare=%s, encoder zero=%s, thermal drift %.3g Nm/K, random walk" % (
            dev["sensor"]["tare"], dev["encoder"]["zero"], dev["sensor"]["thermal_nm_per_K"]),
        "the drift inside each repetition is not a constant offset")
    ib = dev["internal_bearing"]
    add(expected, "viscous_friction", "friction_visc", {"damping_nms_per_rad": ib["sigma2"]},
        "internal-bearing viscous term (temperature dependent, %.3g /K)" % ib["visc_temp_coeff_per_K"])
    add(ambiguous, "coulomb_friction", "friction_coulomb", {"Fc_nm": ib["Fc"], "load_coeff": ib["load_coeff"]},
        "internal-bearing LuGre (pre-sliding z_ss %.2g rad)" % ib["z_ss"],
        "the baseline's arctan already has this form; only named if the tool's arctan parameters are fixed and differ; friction grows with the spring load")
    add(expected, "stribeck_friction", "friction_stribeck", {"Fs_nm": ib["Fs"], "Fc_nm": ib["Fc"], "vs_rad_s": ib["vs"], "shape_exponent": ib["alpha"]},
        "internal-bearing Stribeck dip")
    add(expected, "time_delay", "sensor_dynamics", {"delay_s": sess["delay_s"], "lpf_hz": dev["sensor"]["lpf_hz"],
                                                     "transport_s": dev["sensor"]["transport_s"], "sensor_rate_hz": dev["sensor"]["fs_hz"]},
        "2nd-order low-pass + sample-and-hold + transport latency, torque lags the deflection",
        "delay_s is the low-frequency equivalent lag (transport + half a sensor period + filter group delay - encoder read latency)")
    add(expected, "vibration", "inertial", {"frequency_hz": vib_peak_hz, "output_mode_hz": dev["output"]["mode_hz"],
                                             "zeta": dev["output"]["zeta"], "amplitude_rms_nm": raw["inertial"],
                                             "drive_mode_hz": dev["drive"]["mode_hz"]},
        "output flange on the fixture compliance, excited by reversals, seal stick-slip, cogging and gear error",
        "frequency_hz is the spectral peak of the inertial torque in this file (between the two rig modes when they couple); bursts after reversals, sustained where the seal's Stribeck slope chatters; the drive-side mode moves deflection and torque together")
    if dev["clearance"] is not None:
        cl = dev["clearance"]
        add(expected, "dead_zone", "clearance", {"half_width_rad": cl["half_width_rad"], "total_play_rad": 2 * cl["half_width_rad"],
                                                  "contact_eps_rad": cl["contact_eps_rad"], "centre_rad_true": cl["centre_rad"]},
            "keyed-hub clearance with smooth contact inside the encoder span")
    # stiffness error (conditional on a configured nominal)
    kdat = sp["k_datasheet_nm_per_rad"]
    kapp = float(c0[0])
    entry = {"cause": "stiffness_error", "params": {"k_datasheet_nm_per_rad": kdat, "k0_true_nm_per_rad": k0,
                                                      "k_apparent_fit_nm_per_rad": kapp, "relative_error": kapp / kdat - 1},
             "model": "datasheet stiffness vs the stiffness in this record (spring tolerance, sensor gain %.4f, encoder radius error %.4f)" % (
                 dev["sensor"]["gain"], dev["encoder"]["gain_error"]),
             "visible_rms_nm": abs(kapp - kdat) * rms(dmeas),
             "note": "conditional: only meaningful if the tool is given a nominal k; the record alone cannot show it"}
    ambiguous.append(entry)
    # not in vocabulary
    en = dev["encoder"]
    def nv(effect, key, params, note=""):
        e = {"effect": effect, "params": params, "visible_rms_nm": vis[key] if key else None, "raw_rms_nm": raw[key] if key else None}
        if note:
            e["note"] = note
        nov.append(e)
    nv("encoder scale interpolation error (periodic in deflection) + reading hysteresis + flicker + quantisation + radius error", "encoder",
       {"pitch_rad": en["angular_pitch_rad"], "sde_rad": en["sde_rad"], "hysteresis_rad": en["hysteresis_rad"],
        "noise_lsb": en["noise_lsb"], "gain_error": en["gain_error"]},
       "periodic in deflection with the pole pitch; reading hysteresis makes a thin rate-independent loop")
    nv("bypass friction of the output bearing (parallel to the sensor, pre-sliding)", "bypass",
       dev["output"]["bearing"], "looks like a small extra hysteresis/Coulomb loop")
    if dev["viscoelastic"]["branches"]:
        nv("elastomer viscoelastic relaxation (generalised Maxwell)", "viscoelastic", dev["viscoelastic"],
           "rate-dependent: between viscous_friction and hysteresis; amplitude-independent loop shape")
    nv("6-axis crosstalk rotating with the drive angle", "crosstalk", {"fraction": dev["sensor"]["crosstalk"]},
       "a torque*angle term: mostly an asymmetric (quadratic) stiffness change")
    nv("torque sensor gain error", "gain", {"gain": dev["sensor"]["gain"]}, "indistinguishable from stiffness")
    nv("temperature dependence of the stiffness", "thermal_stiffness", {"kappa_per_K": sp["kappa_T_per_K"]})
    nv("50 Hz mains pickup", "hum", {"rms_nm": dev["sensor"]["hum_nm"]})
    nv("1/f torque noise", "pink", {"rms_nm": dev["sensor"]["pink_nm"]})
    nv("drive imperfections (gear kinematic error, cogging, seal stick-slip at reversals, re-homing between repetitions)", None,
       {"kinematic_error_rad": dev["drive"]["kinematic_error_rad"], "cogging_nm": dev["drive"]["cogging_nm"],
        "seal": dev["drive"]["seal"], "rehome_sigma_rad": dev["drive"]["rehome_sigma_rad"]},
       "shape the motion only; seen through the dynamics and the friction rate")
    nv("logger timing: irregular intervals, stalls, buffered bursts stamped late, long gaps, stamp jitter", None, dev["logger"],
       "after a buffered stall several samples carry nearly the same stamp although they were read at regular times")
    finish_causes(expected, ambiguous, below, r0)
    # file facts
    starts = [int(np.nonzero(rep_local == r)[0][0]) for r in range(len(uniq))]
    t_ranges = [[float(wall[rep_local == r][0]), float(wall[rep_local == r][-1])] for r in range(len(uniq))]
    ans = {
        "device": dev["name"], "variant": variant, "kind": "rig",
        "fs_nominal": 20.0 if binned else 550.0,
        "noise_white_nm": noise_white, "noise_floor_nm": noise_floor,
        "noise_floor_parts_nm": {"white": noise_white, "pink_demeaned_per_repetition": rms(coloured),
                                  "hum": rms(comp["hum"]), "quantisation": rms(comp["quantisation"])},
        "encoder_noise_torque_equiv_nm": float(k0 * ENC_LSB * math.sqrt(1 / 12 + en["noise_lsb"] ** 2)
                                               / (math.sqrt(float(np.median(nper))) if binned else 1.0)),
        "visible_threshold_nm": thr,
        "expected_causes": expected, "ambiguous_causes": ambiguous, "present_below_threshold": below,
        "not_in_vocabulary": nov,
        "samples": int(len(tmeas)), "repetitions": len(uniq), "repetition_start_rows": starts,
        "repetition_time_ranges": t_ranges,
        "time": time_stats(wall, rep_local),
        "time_jump": "time continues across repetitions with pauses of %s s" % ", ".join(
            "%.1f" % (t_ranges[i + 1][0] - t_ranges[i][1]) for i in range(len(uniq) - 1)) if len(uniq) > 1 else None,
        "time_base": "Unix epoch seconds (logger stamps)",
        "sampling": "binned to 20 Hz means (bins aligned to the epoch, not crossing repetitions)" if binned else "irregular ~550 Hz",
        "encoder": "magnetic linear encoder, 2e-6 rad steps" + (" (bin-averaged, off the grid)" if binned else ""),
        "encoder_lsb_rad": ENC_LSB, "deflection_is_position": False,
        "drive": {"waveform": dev["test"]["waveform"], "timing": dev["test"]["timing"],
                  "amplitude_indices": amps_in,
                  "amplitudes_rad": [float(dev["test"]["amplitudes_rad"][a]) for a in amps_in],
                  "frequencies_hz": sorted(set(round(reps[r]["freq_hz"], 6) for r in uniq)),
                  "session_repetitions": [reps[r]["index"] for r in uniq]},
        "deflection_span_rad": dspan, "deflection_mid_rad": dmid,
        "k_nm_per_rad": k0, "tau_max_nm": dev["spring"]["tau_max_nm"],
        "temperature_C": [float(np.min(sess["temp_C"][mask])), float(np.max(sess["temp_C"][mask]))],
        "component_rms_nm": raw, "component_visible_rms_nm": vis,
        "component_doc": RIG_COMPONENT_DOC,
        "diagnostics": diag,
        "physics": {k: v for k, v in dev.items() if k not in ("name", "kind")},
    }
    if binned:
        ans["samples_per_bin_median"] = float(np.median(nper))
    return ans, wall, dmeas, tmeas


# ----------------------------------------------------------------------------- arm joints

def sample_arm_device(rng, idx):
    proximal = (idx % 2 == 0)
    name = f"a{idx + 1}"
    if proximal:
        N = int(rng.choice([100, 160]))
        G = un(rng, 15, 60)
        Fc = un(rng, 1.5, 6.0)
        b1 = un(rng, 1.0, 6.0)
        Jres = lu(rng, 0.01, 0.2)
        sw = lu(rng, 0.01, 0.04)
        span = un(rng, 1.0, 2.5)
        vmax = un(rng, 0.6, 1.2)
        acc = un(rng, 1.0, 4.0)
        kc = un(rng, 0.0, 0.6)
    else:
        N = int(rng.choice([100, 120]))
        G = un(rng, 1.0, 8.0)
        Fc = un(rng, 0.3, 1.5)
        b1 = un(rng, 0.2, 1.2)
        Jres = lu(rng, 0.001, 0.02)
        sw = lu(rng, 0.003, 0.015)
        span = un(rng, 1.5, 3.0)
        vmax = un(rng, 0.8, 2.0)
        acc = un(rng, 2.0, 8.0)
        kc = un(rng, 0.0, 0.15)
    asym = un(rng, -0.15, 0.15)
    v1 = max(lu(rng, 0.03, 0.08), span / 60.0)
    dev = {
        "name": name, "kind": "arm_friction", "joint": "proximal" if proximal else "distal",
        "gear_ratio": N,
        "friction": {
            "Fc_pos": Fc * (1 + asym), "Fc_neg": Fc * (1 - asym),
            "Fs_ratio": un(rng, 1.1, 1.6), "vs_rad_s": lu(rng, 0.005, 0.06), "alpha": un(rng, 0.6, 2.0),
            "b_pos": b1 * (1 + un(rng, -0.1, 0.1)), "b_neg": b1 * (1 + un(rng, -0.1, 0.1)),
            "viscous_exponent": un(rng, 0.55, 1.0),
            "visc_temp_coeff_per_K": un(rng, 0.01, 0.03), "coulomb_temp_coeff_per_K": un(rng, 0.001, 0.005),
            "load_coeff_per_nm": un(rng, 0.05, 0.4) / G, "z_ss_rad": lu(rng, 1.5e-4, 1e-3), "sigma1": 0.0,
        },
        "ripple": {"r2": un(rng, 0.03, 0.12), "r1": un(rng, 0.01, 0.05), "rlink": un(rng, 0.0, 0.03),
                   "phase": [un(rng, 0, 2 * math.pi) for _ in range(3)]},
        "gravity": {"G_nm": G, "phi": un(rng, 0, 2 * math.pi), "eps_mass": un(rng, -0.05, 0.05), "eps_angle": un(rng, -0.03, 0.03)},
        "cable": {"k_nm_per_rad": kc, "q0": un(rng, -1, 1)},
        "inertia_residual_kgm2": Jres,
        "tracking": {"bandwidth_hz": un(rng, 8, 25), "zeta": un(rng, 0.7, 0.95)},
        "sensor": {"white_nm": sw, "pink_nm": sw * un(rng, 0.3, 1.0), "offset_nm": sgn(rng) * un(rng, 0.02, 0.3) * Fc,
                   "thermal_nm_per_K": sgn(rng) * lu(rng, 0.003, 0.03), "random_walk_nm_per_sqrt_s": lu(rng, 1e-4, 1e-3),
                   "lpf_hz": lu(rng, 60, 250), "quantum_nm": lu(rng, 2e-4, 2e-3)},
        "encoder": {"bits": int(rng.choice([19, 20, 21])), "cyclic_rad": [lu(rng, 5e-6, 5e-5), lu(rng, 2e-6, 2e-5)],
                    "cyclic_phase": [un(rng, 0, 2 * math.pi), un(rng, 0, 2 * math.pi)]},
        "thermal": {"T0_C": un(rng, 25, 35), "rise_K": un(rng, 2, 10), "tau_s": lu(rng, 600, 2000)},
        "motion": {"centre_rad": un(rng, -1, 1), "span_rad": span, "speeds_rad_s": [v1, lu(rng, 0.15, 0.35), vmax],
                   "acc_rad_s2": acc, "dwell_s": un(rng, 0.2, 1.0), "order": "sweep_first" if rng.random() < 0.5 else "sine_first",
                   "target_s": un(rng, 40, 100)},
        "packet_loss": lu(rng, 2e-5, 3e-4),
    }
    return dev


def arm_trajectory(dev, case, v, fs):
    m = dev["motion"]
    qlo = m["centre_rad"] - m["span_rad"] / 2
    qhi = m["centre_rad"] + m["span_rad"] / 2
    dwell = m["dwell_s"]
    acc = m["acc_rad_s2"]
    span = qhi - qlo
    if case == "sweep":
        one = span / v
        n = int(np.clip(round(m["target_s"] / (2 * one)), 1, 5))
        # one pass: trapezoidal velocity
        ta = v / acc
        if 2 * ta > one:
            ta = one / 2
        T = span / v + ta
        tt = np.arange(0, T, 1 / fs)
        vel = np.minimum.reduce([np.full_like(tt, v), acc * tt, acc * (T - tt)])
        vel = np.maximum(vel, 0)
        pos = np.cumsum(vel) / fs
        pos *= span / pos[-1]
        seq = [np.full(int(1.0 * fs), qlo)]
        for _ in range(n):
            seq += [qlo + pos, np.full(int(dwell * fs), qhi), qhi - pos, np.full(int(dwell * fs), qlo)]
        seq.append(np.full(int(0.5 * fs), qlo))
        q = np.concatenate(seq)
    else:
        A = span / 2
        f = v / (2 * np.pi * A)
        n = int(np.clip(round(m["target_s"] * f), 1, 6))
        tt = np.arange(0, n / f, 1 / fs)
        q = np.concatenate([np.full(int(1.0 * fs), qlo), m["centre_rad"] - A * np.cos(2 * np.pi * f * tt),
                            np.full(int(0.5 * fs), qlo)])
    return q


def arm_files(seed, idx):
    rng = np.random.default_rng([seed, 2000 + idx, 23])
    dev = sample_arm_device(rng, idx)
    fs = FS_ARM
    m = dev["motion"]
    runs = [("sweep", i) for i in range(3)] + [("sine", i) for i in range(3)]
    if m["order"] == "sine_first":
        runs = runs[3:] + runs[:3]
    wall = 0.0
    th = dev["thermal"]
    out = []
    o_rw = 0.0
    fr = dev["friction"]
    s0 = 0.5 * (fr["Fc_pos"] + fr["Fc_neg"]) * fr["Fs_ratio"] / fr["z_ss_rad"]
    for case, si in runs:
        v = m["speeds_rad_s"][si]
        qref = arm_trajectory(dev, case, v, fs)
        n = len(qref)
        # tracking (joint position controller), 2nd order
        wn = 2 * np.pi * dev["tracking"]["bandwidth_hz"]
        zt = dev["tracking"]["zeta"]
        bz, az = signal.bilinear([wn * wn], [1, 2 * zt * wn, wn * wn], fs)
        q = signal.lfilter(bz, az, qref, zi=signal.lfilter_zi(bz, az) * qref[0])[0]
        qd = np.gradient(q) * fs
        qdd = np.gradient(qd) * fs
        t = np.arange(n) / fs
        T = th["T0_C"] + th["rise_K"] * (1 - np.exp(-(wall + t) / th["tau_s"]))
        dT = T - th["T0_C"]
        g = dev["gravity"]
        grav = g["G_nm"] * np.cos(q + g["phi"])
        lf = 1 + fr["load_coeff_per_nm"] * np.abs(grav)
        cT = 1 - fr["coulomb_temp_coeff_per_K"] * dT
        Fc_arr = np.where(qd >= 0, fr["Fc_pos"], fr["Fc_neg"]) * lf * cT
        Fs_arr = Fc_arr * fr["Fs_ratio"]
        bdir = np.where(qd >= 0, fr["b_pos"], fr["b_neg"]) * np.exp(-fr["visc_temp_coeff_per_K"] * dT)
        visc = bdir * np.sign(qd) * np.abs(qd) ** fr["viscous_exponent"]
        # LuGre bristle loop
        zl = array.array("d", bytes(8 * n))
        z = 0.0
        dt = 1 / fs
        qdl = qd.tolist()
        Fcl = Fc_arr.tolist()
        Fsl = Fs_arr.tolist()
        vs = fr["vs_rad_s"]
        al = fr["alpha"]
        for i in range(n):
            z = lugre_step(z, qdl[i], Fcl[i], Fsl[i], vs, al, s0, dt)
            zl[i] = z
        zarr = np.frombuffer(zl, dtype=float).copy()
        dry = s0 * zarr
        gv = Fc_arr + (Fs_arr - Fc_arr) * np.exp(-(np.abs(qd) / vs) ** al)
        strib = dry * np.clip((gv - Fc_arr) / gv, 0, 1)
        coul = dry - strib
        rp = dev["ripple"]
        Fcm = 0.5 * (fr["Fc_pos"] + fr["Fc_neg"])
        N = dev["gear_ratio"]
        ripple = Fcm * (rp["r2"] * np.sin(2 * N * q + rp["phase"][0]) + rp["r1"] * np.sin(N * q + rp["phase"][1])
                        + rp["rlink"] * np.sin(q + rp["phase"][2]))
        grav_err = g["G_nm"] * (g["eps_mass"] * np.cos(q + g["phi"]) + g["eps_angle"] * np.sin(q + g["phi"]))
        cable = dev["cable"]["k_nm_per_rad"] * (q - dev["cable"]["q0"])
        inertial = dev["inertia_residual_kgm2"] * qdd
        comp = {"friction_coulomb": coul, "friction_stribeck": strib, "friction_visc": visc, "ripple": ripple,
                "gravity_model_error": grav_err, "cable": cable, "inertial": inertial}
        total = sum(comp.values())
        se = dev["sensor"]
        b, a = signal.butter(2, se["lpf_hz"] / (fs / 2))
        filt = signal.lfilter(b, a, total, zi=signal.lfilter_zi(b, a) * total[0])[0]
        comp["sensor_dynamics"] = filt - total
        rw = o_rw + np.cumsum(rng.standard_normal(n)) * se["random_walk_nm_per_sqrt_s"] * math.sqrt(dt)
        o_rw = float(rw[-1])
        comp["offset_drift"] = se["offset_nm"] + se["thermal_nm_per_K"] * dT + rw
        comp["white"] = se["white_nm"] * rng.standard_normal(n)
        comp["pink"] = se["pink_nm"] * pink_noise(rng, n, fs)
        pre = sum(comp.values())
        qq = se["quantum_nm"]
        tmeas = np.rint(pre / qq) * qq
        comp["quantisation"] = tmeas - pre
        en = dev["encoder"]
        lsb = 2 * np.pi / 2 ** en["bits"]
        qm = q + en["cyclic_rad"][0] * np.sin(q + en["cyclic_phase"][0]) + en["cyclic_rad"][1] * np.sin(2 * q + en["cyclic_phase"][1])
        qmeas = np.rint(qm / lsb) * lsb
        # time: controller clock, 1 kHz, rare lost packets
        keep = rng.random(n) >= dev["packet_loss"]
        keep[0] = keep[-1] = True
        tt = t[keep]
        comp = {k: v_[keep] for k, v_ in comp.items()}
        out.append({"case": case, "speed_index": si, "speed": v, "t": tt, "q": qmeas[keep], "tau": tmeas[keep],
                    "qd": qd[keep], "comp": comp, "T": T[keep], "wall_start": wall, "lsb": lsb})
        wall += n / fs + un(rng, 10, 120)
    return dev, out


def arm_answers(dev, run):
    comp = run["comp"]
    q = run["q"]
    tau = run["tau"]
    qd = run["qd"]
    white = comp["white"]
    coloured = comp["pink"] - comp["pink"].mean()
    floor = white + coloured + comp["quantisation"]
    noise_white = rms(white)
    noise_floor = rms(floor)
    r0, c0, kb = fit_baseline(q, tau, qd)
    X = np.column_stack([q, atan_reg(qd, kb)])
    vis = {k: visible(v, X) for k, v in comp.items()}
    raw = {k: rms(v) for k, v in comp.items()}
    thr = VISIBLE_FACTOR * noise_floor
    fr = dev["friction"]
    expected, ambiguous, below, nov = [], [], [], []

    def add(lst, cause, key, params, model, note=""):
        v = visible(sum(comp[k] for k in key), X) if isinstance(key, (list, tuple)) else vis[key]
        file_entry(lst, below, v >= thr, {"cause": cause, "params": params, "model": model, "visible_rms_nm": v}, note)

    dT = run["T"] - dev["thermal"]["T0_C"]
    bmean = 0.5 * (fr["b_pos"] + fr["b_neg"]) * float(np.mean(np.exp(-fr["visc_temp_coeff_per_K"] * dT)))
    vabs = np.abs(qd[np.abs(qd) > 0.2 * run["speed"]])
    # effective linear damping over this file's speeds (LS slope of b*|v|^gamma through 0)
    if vabs.size:
        bv = bmean * vabs ** fr["viscous_exponent"]
        beff = float(np.sum(bv * vabs) / np.sum(vabs * vabs))
    else:
        beff = bmean
    add(expected, "viscous_friction", "friction_visc",
        {"damping_nms_per_rad": beff, "b_at_1rad_s": bmean, "exponent": fr["viscous_exponent"],
         "b_pos": fr["b_pos"], "b_neg": fr["b_neg"]},
        "b*|v|^gamma per direction, viscosity falling with temperature (%.3g /K)" % fr["visc_temp_coeff_per_K"],
        "damping_nms_per_rad is the best linear slope over this file's speeds; the law is not linear when gamma<1")
    add(expected, "stribeck_friction", "friction_stribeck",
        {"Fs_minus_Fc_nm": (fr["Fs_ratio"] - 1) * 0.5 * (fr["Fc_pos"] + fr["Fc_neg"]), "vs_rad_s": fr["vs_rad_s"],
         "shape_exponent": fr["alpha"]}, "generalised Stribeck inside LuGre")
    add(ambiguous, "coulomb_friction", "friction_coulomb",
        {"Fc_pos_nm": fr["Fc_pos"], "Fc_neg_nm": fr["Fc_neg"], "load_coeff_per_nm": fr["load_coeff_per_nm"],
         "z_ss_rad": fr["z_ss_rad"]},
        "LuGre at the Coulomb level, direction dependent, growing with gravity load, falling with temperature",
        "the baseline's arctan already has this form; the direction asymmetry (Fc_pos-Fc_neg)/2 acts as an offset while moving")
    off = comp["offset_drift"] + comp["gravity_model_error"] + comp["cable"]
    add(expected, "sensor_offset", ["offset_drift", "gravity_model_error", "cable"],
        {"offset_nm": float(np.mean(off)), "sensor_offset_nm": float(np.mean(comp["offset_drift"])),
         "gravity_error_mean_nm": float(np.mean(comp["gravity_model_error"])),
         "coulomb_asymmetry_nm": 0.5 * (fr["Fc_pos"] - fr["Fc_neg"])},
        "torque sensor offset (thermal drift, random walk) plus the mean over this file of the position-dependent gravity-model error and cable drag",
        "the gravity-model error varies with position; its mean depends on the range covered")
    add(ambiguous, "time_delay", "sensor_dynamics", {"lpf_hz": dev["sensor"]["lpf_hz"],
                                                     "delay_s": math.sqrt(2) / (2 * math.pi * dev["sensor"]["lpf_hz"])},
        "torque sensor low-pass", "small; visible mainly at speed reversals")
    finish_causes(expected, ambiguous, below, r0)
    rp = dev["ripple"]
    nov.append({"effect": "gear ripple periodic in joint angle x gear ratio (2N and N) and once per link turn",
                "params": {"gear_ratio": dev["gear_ratio"], **rp, "Fc_mean_nm": 0.5 * (fr["Fc_pos"] + fr["Fc_neg"])},
                "visible_rms_nm": vis["ripple"],
                "note": "at constant speed v it is a tone at v*2N/(2pi) Hz; a function of position, not of time"})
    nov.append({"effect": "link inertia not removed by the gravity-only model", "params": {"J_kgm2": dev["inertia_residual_kgm2"]},
                "visible_rms_nm": vis["inertial"], "note": "spikes at sweep turnarounds; for sines a term proportional to -(q-centre)"})
    nov.append({"effect": "gravity-model error (position dependent) and cable drag", "params": {**dev["gravity"], "cable": dev["cable"],
                "slope_nm_per_rad": float(np.polyfit(q, comp["gravity_model_error"] + comp["cable"], 1)[0])},
                "visible_rms_nm": vis["gravity_model_error"] + vis["cable"],
                "note": "a smooth function of the position column; its mean is counted in sensor_offset, its linear part is absorbed by the baseline's k*deflection (no spring here)"})
    nov.append({"effect": "load- and temperature-dependent friction", "params": {"load_coeff_per_nm": fr["load_coeff_per_nm"],
                "coulomb_temp_coeff_per_K": fr["coulomb_temp_coeff_per_K"], "visc_temp_coeff_per_K": fr["visc_temp_coeff_per_K"]},
                "visible_rms_nm": None})
    nov.append({"effect": "1/f torque noise", "params": {"rms_nm": dev["sensor"]["pink_nm"]}, "visible_rms_nm": vis["pink"]})
    ans = {
        "device": dev["name"], "variant": f"{run['case']}-v{run['speed_index'] + 1}", "kind": "arm_friction",
        "fs_nominal": FS_ARM, "noise_white_nm": noise_white, "noise_floor_nm": noise_floor,
        "noise_floor_parts_nm": {"white": noise_white, "pink_demeaned": rms(coloured), "quantisation": rms(comp["quantisation"])},
        "visible_threshold_nm": thr,
        "expected_causes": expected, "ambiguous_causes": ambiguous, "present_below_threshold": below,
        "not_in_vocabulary": nov,
        "samples": int(len(tau)), "repetitions": 1, "repetition_start_rows": [0],
        "time": time_stats(run["t"], np.zeros(len(run["t"]), int)),
        "time_jump": None, "time_base": "controller clock, seconds from the start of the run",
        "sampling": "1 kHz (rare lost packets)", "encoder": f"{dev['encoder']['bits']}-bit link-side absolute",
        "encoder_lsb_rad": run["lsb"], "deflection_is_position": True,
        "motion": {"case": run["case"], "speed_rad_s": run["speed"], "speed_index": run["speed_index"],
                   "range_rad": [float(q.min()), float(q.max())]},
        "temperature_C": [float(run["T"].min()), float(run["T"].max())],
        "k_nm_per_rad": 0.0,
        "component_rms_nm": raw, "component_visible_rms_nm": vis,
        "diagnostics": {"baseline_linear_plus_arctan_rms_nm": r0, "baseline_k_nm_per_rad": float(c0[0]),
                        "baseline_ka_nm": float(c0[1]), "baseline_kb_s_per_rad": float(kb)},
        "physics": {k: v for k, v in dev.items() if k not in ("name", "kind")},
        "assumption": "the record is the joint friction as the maintainers describe it (link-side torque minus a gravity model); what that subtraction leaves besides friction is modelled as gravity-model error, cable drag and an inertia residual",
    }
    return ans


# ----------------------------------------------------------------------------- output

def write_csv(path, t, d, tau, dfmt):
    with open(path, "w") as fh:
        fh.write("t,deflection,torque\n")
        fmt = "%.6f," + dfmt + ",%.6f"
        chunk = 20000
        for s in range(0, len(t), chunk):
            fh.write("\n".join(fmt % row for row in zip(t[s:s + chunk].tolist(), d[s:s + chunk].tolist(),
                                                        tau[s:s + chunk].tolist())))
            fh.write("\n")


def generate_seed(seed, out_dir, verbose=True):
    t_start = time.time()
    folder = os.path.join(out_dir, f"rig{seed}")
    os.makedirs(folder, exist_ok=True)
    answers = {}
    for di in range(N_RIG_DEVICES):
        t0 = time.time()
        sess = rig_session(seed, di)
        dev = sess["dev"]
        reps = sess["reps"]
        test = dev["test"]
        rid = sess["rep_id"]
        amp_of = np.array([reps[r]["amp_index"] for r in rid])
        repn_of = np.array([reps[r]["rep"] for r in rid])
        ref = test["reference_amplitude_index"]
        variants = [
            ("amp5", np.ones(len(rid), bool), False),
            ("full3", amp_of == ref, False),
            ("rep1", (amp_of == ref) & (repn_of == test["rep1_index"]), False),
            ("bin20", amp_of == ref, True),
            ("amp1", amp_of == test["one_amplitude_index"], False),
        ]
        for vname, mask, binned in variants:
            ans, tw, dm, tm = rig_file_answers(sess, vname, mask, binned)
            fname = f"{dev['name']}-{vname}.csv"
            write_csv(os.path.join(folder, fname), tw, dm, tm, "%.9f" if binned else "%.6f")
            ans["file"] = fname
            answers[fname] = ans
        if verbose:
            print(f"  seed {seed} rig {dev['name']}: {len(rid)} session samples, {time.time() - t0:.1f} s", flush=True)
    for ai in range(N_ARM_DEVICES):
        t0 = time.time()
        dev, runs = arm_files(seed, ai)
        for run in runs:
            ans = arm_answers(dev, run)
            fname = f"{dev['name']}-{run['case']}-v{run['speed_index'] + 1}.csv"
            write_csv(os.path.join(folder, fname), run["t"], run["q"], run["tau"], "%.9f")
            ans["file"] = fname
            answers[fname] = ans
        if verbose:
            print(f"  seed {seed} arm {dev['name']}: {sum(len(r['t']) for r in runs)} samples, {time.time() - t0:.1f} s", flush=True)
    meta = {"generator": GENERATOR_VERSION, "seed": seed, "vocabulary": list(VOCAB),
            "visible_factor": VISIBLE_FACTOR}
    with open(os.path.join(folder, "answers.json"), "w") as fh:
        json.dump(jsonable({"_meta": meta, **answers}), fh, indent=1)
    return folder, time.time() - t_start


# ----------------------------------------------------------------------------- check

REQUIRED_KEYS = ("device", "variant", "kind", "fs_nominal", "noise_white_nm", "noise_floor_nm", "physics",
                 "expected_causes", "not_in_vocabulary")


def folder_size(path):
    return sum(os.path.getsize(os.path.join(path, f)) for f in os.listdir(path))


def file_digest(path):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for blk in iter(lambda: fh.read(1 << 20), b""):
            h.update(blk)
    return h.hexdigest()


def run_check(seed, compare_dir=None):
    passed = failed = 0
    msgs = []

    def ok(cond, what):
        nonlocal passed, failed
        if cond:
            passed += 1
        else:
            failed += 1
            msgs.append("FAIL: " + what)

    tmp = tempfile.mkdtemp(prefix="riggen-check-")
    try:
        t0 = time.time()
        folder, _ = generate_seed(seed, tmp, verbose=False)
        gen_s = time.time() - t0
        ok(gen_s < 180, f"generation time {gen_s:.1f} s < 180 s")
        size = folder_size(folder)
        ok(size < 400e6, f"folder size {size / 1e6:.1f} MB < 400 MB")
        ans = json.load(open(os.path.join(folder, "answers.json")))
        csvs = sorted(f for f in os.listdir(folder) if f.endswith(".csv"))
        ok(len(csvs) == 5 * N_RIG_DEVICES + 6 * N_ARM_DEVICES, f"file count {len(csvs)}")
        ok(set(csvs) == set(k for k in ans if k != "_meta"), "answers cover exactly the CSV files")
        devs_rig = {}
        for f in csvs:
            a = ans.get(f, {})
            for k in REQUIRED_KEYS:
                ok(k in a, f"{f}: answers key {k}")
            for e in a.get("expected_causes", []) + a.get("ambiguous_causes", []):
                ok(e.get("cause") in VOCAB, f"{f}: cause {e.get('cause')} in vocabulary")
            ok(a.get("noise_floor_nm", 0) >= a.get("noise_white_nm", 1) * 0.999, f"{f}: floor >= white")
            with open(os.path.join(folder, f)) as fh:
                head = fh.readline().strip()
            ok(head == "t,deflection,torque", f"{f}: header")
            data = np.loadtxt(os.path.join(folder, f), delimiter=",", skiprows=1)
            ok(data.ndim == 2 and data.shape[1] == 3, f"{f}: three columns")
            ok(np.all(np.isfinite(data)), f"{f}: finite values")
            ok(len(data) == a.get("samples"), f"{f}: rows {len(data)} == answers samples {a.get('samples')}")
            t = data[:, 0]
            starts = list(a.get("repetition_start_rows", [0])) + [len(t)]
            mono = all(np.all(np.diff(t[starts[i]:starts[i + 1]]) > 0) for i in range(len(starts) - 1))
            ok(mono, f"{f}: time strictly increasing within repetitions")
            ok(len(starts) - 1 == a.get("repetitions"), f"{f}: repetition count")
            if a.get("kind") == "rig":
                devs_rig.setdefault(a["device"], []).append(f)
                ok(1.6e9 < t[0] < 1.8e9, f"{f}: epoch time stamps")
                if a["variant"] != "bin20":
                    c = data[:, 1] / ENC_LSB
                    ok(np.max(np.abs(c - np.rint(c))) < 1e-3, f"{f}: deflection on the 2e-6 rad grid")
                    st = a["time"]
                    ok(1.5 < st["median_dt_ms"] < 2.1, f"{f}: median dt {st['median_dt_ms']:.2f} ms")
                    if a["samples"] > 5000:
                        ok(6 < st["p99_dt_ms"] < 30, f"{f}: p99 dt {st['p99_dt_ms']:.1f} ms")
                    ok(st["max_dt_within_repetition_s"] <= 0.3, f"{f}: largest gap {st['max_dt_within_repetition_s']:.3f} s")
                    if a["variant"] in ("amp5", "full3"):
                        ok(9000 <= a["samples"] <= 230000, f"{f}: {a['samples']} samples in the real records' range")
                else:
                    ok(abs(a["time"]["median_dt_ms"] - 50) < 1, f"{f}: 20 Hz bins")
                if a["variant"] in ("full3", "amp5", "amp1", "bin20"):
                    ok(a["repetitions"] == (15 if a["variant"] == "amp5" else 3), f"{f}: repetitions")
            else:
                ok(abs(a["time"]["median_dt_ms"] - 1.0) < 1e-3, f"{f}: 1 kHz")
                ok(a.get("deflection_is_position") is True, f"{f}: position column flagged")
        for d, fl in devs_rig.items():
            ok(len(fl) == 5, f"rig device {d} has 5 variants")
            ks = {json.dumps(ans[f]["physics"], sort_keys=True) for f in fl}
            ok(len(ks) == 1, f"rig device {d}: same physics in all variants")
        if compare_dir:
            ref = os.path.join(compare_dir, f"rig{seed}")
            if os.path.isdir(ref):
                same = all(os.path.exists(os.path.join(ref, f)) and file_digest(os.path.join(ref, f)) == file_digest(os.path.join(folder, f))
                           for f in csvs + ["answers.json"])
                ok(same, f"deterministic: regenerated seed {seed} equals {ref}")
        print(f"check seed {seed}: generated in {gen_s:.1f} s, {size / 1e6:.1f} MB, {len(csvs)} CSV files")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for m in msgs:
        print(m)
    print(f"{passed} passed / {failed} failed")
    return failed == 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="output directory (DIR/rig<seed>/...)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[])
    ap.add_argument("--check", action="store_true", help="regenerate one seed in a temp dir and verify")
    ap.add_argument("--seed", type=int, default=1, help="seed for --check (default 1)")
    args = ap.parse_args(argv)
    if args.check:
        return 0 if run_check(args.seed, args.out) else 1
    if not args.out or not args.seeds:
        ap.error("--out and --seeds are required (or --check)")
    for s in args.seeds:
        folder, secs = generate_seed(s, args.out)
        print(f"seed {s}: {folder} {folder_size(folder) / 1e6:.1f} MB in {secs:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
