//! Causes in the loop, not in the joint: from a closed-loop recording (a torque-tracking run:
//! reference, set-points, readings), how late the readings are, how late the set-points arrive
//! and how the drive follows them (its profile limits), the factors section 6.2 blames for the
//! 0.2 Hz limit. Each is a value of the simulation's `hal.sim` section; a value that makes the
//! recording's held-out part significantly better explained than the configured one is a cause.
//!
//! - **Feedback latency** of a device group (the joint's drives over CAN, its encoders over SPI):
//!   the F/T sensor is taken as the fresh signal; the group's readings, shifted earlier by `L`,
//!   explain the F/T torque's *rate* best at the true `L`. Rates, not levels: the torque's level
//!   carries the joint's hysteresis band, which shifts a level fit's best `L` by several ms; at
//!   the rates of a tracking run the band is a small constant.
//! - **Command latency and the drive's response**: the joint's drives replayed from the recorded
//!   set-points (each arriving `L_cmd` after its cycle), the same ELMO model as the simulation
//!   ([`jointctl_sim::elmo::ElmoDrive`]: trapezoidal profile, PID, inertia) against the recorded
//!   load (the F/T torque through the joint's transmission), compared with the drives' readings
//!   shifted by their feedback latency. `L_cmd`, the profile's acceleration and velocity limits
//!   and the position loop's stiffness (kp, which shows wherever the load changes) are searched
//!   together (they trade off); a limit the recording never reaches is said to be so, not
//!   guessed. The response is tested as a whole (a limit shows only at the steps
//!   that reach it); a part of it is named when its configured value makes the fit clearly worse.
//!
//! Both are fitted on the first 70 % of the time range and scored on the rest (as `identify`).

use std::path::Path;

use jointctl_config::{ElmoConfig, LoadedConfig};
use jointctl_ident::identify::prepare::split_time;
use jointctl_ident::identify::significance::log_ratio_block_test;
use jointctl_sim::elmo::ElmoDrive;
use serde::Serialize;

use crate::ExperimentError;

mod feedback;
mod load;
mod search;
use feedback::feedback_latency;
use search::{block_rms_where, nelder_mead, search};

/// Latencies searched [s]: 0 to 100 ms, the range the configuration accepts (section 2.3's set-up
/// had 15 and 30 ms).
pub const MAX_LATENCY_S: f64 = 0.1;

/// The drive replay's integration step [s] (the simulation's default `substep_s`).
const REPLAY_STEP_S: f64 = 0.0005;

/// A profile limit counts as reached, and a part of the drive's response as needed, when it
/// explains the training part's drive motion this much better than without it, in the fits'
/// objective (the blocks' geometric mean RMS, [`block_rms_where`]: a part that acts in 2 of 20
/// blocks must bring their error down 1.63 times). Assumption: below it the limit is indistinct
/// from the PID's own response.
const LIMIT_EVIDENCE: f64 = 0.05;

/// The drives' position-loop stiffness is searched within this many decades of the configured
/// kp (a factor of 1/30 to 30). Assumption: a drive tuned further off than that is a different
/// drive, not a mis-tuned one.
const KP_DECADES: f64 = 1.5;

/// The stiffness factors' logarithms whose best latencies start the search (1/10 to 10 of the
/// configured kp).
const KP_STARTS: [f64; 5] = [-1.0, -0.5, 0.0, 0.5, 1.0];

/// Acceleration limits tried on the first grid: this many steps over 4 decades (12 a decade,
/// 21 % apart). The fit has a cliff below the true limit (a drive limited below it cannot follow
/// a bang-bang profile, and a later set-point cannot make up for that): with 3 a decade the grid's
/// nearest point above the true limit was more than twice it, and its best point lay in another
/// valley (the shoulder's drives: 100 ms found for 45 ms).
const ACCEL_GRID: usize = 48;

/// One drive's recorded signals.
#[derive(Clone, Debug, Default)]
pub struct DriveTrace {
    /// The drive's name.
    pub name: String,
    /// The set-point sent in each cycle [rad] (NaN: holding, nothing sent).
    pub setpoint_rad: Vec<f64>,
    /// The drive's position reading [rad] (NaN: unknown).
    pub position_rad: Vec<f64>,
    /// The load on the drive per cycle [Nm]: the joint's F/T torques through its transmission
    /// (`M^T tau`, as the simulation loads its drives).
    pub load_nm: Vec<f64>,
    /// The drive's torque reading [Nm] (its current; NaN: unknown): its load where the F/T
    /// sensors do not give it.
    pub torque_nm: Vec<f64>,
    /// Its ELMO settings in the configuration.
    pub elmo: ElmoConfig,
}

/// One DOF's closed-loop recording.
#[derive(Clone, Debug, Default)]
pub struct LoopRecording {
    /// The DOF.
    pub dof: String,
    /// Cycle time [s] from the recorded stamps.
    pub t_s: Vec<f64>,
    /// The DOF's F/T torque [Nm] (NaN: unknown).
    pub sensor_torque_nm: Vec<f64>,
    /// The joint's drives that move its DOFs.
    pub drives: Vec<DriveTrace>,
    /// The joint's encoders: name and readings [rad] (NaN: unknown).
    pub encoders: Vec<(String, Vec<f64>)>,
    /// DOFs of the joint the drives move whose torque was not measured (no F/T sensor): the
    /// drives' `load_nm` lacks their share, which their torque readings give.
    pub unmeasured_dofs: Vec<String>,
    /// Each unmeasured DOF's row of the transmission: its coefficient per drive (`drives` order).
    pub unmeasured_rows: Vec<Vec<f64>>,
}

/// A value of the loop: identified, configured, and how much better it explains the held-out part.
#[derive(Clone, Debug, Serialize)]
pub struct LoopValue {
    /// `feedback_latency_can`, `feedback_latency_spi`, `command_latency`, `drive_max_acceleration`,
    /// `drive_max_velocity`, `drive_kp` (a drive's position-loop proportional gain [Nm/rad]).
    pub name: String,
    /// Its key in the configuration (`hal.sim.can_latency_s`, ...).
    pub key: String,
    /// The identified value (SI: s, rad/s^2, rad/s).
    pub value: f64,
    /// The configured value.
    pub configured: f64,
    /// Held-out RMSE with the configured value (torque rate [Nm/s] for feedback latencies, drive
    /// position [rad] for the drive's response: this value configured, the others identified).
    pub rmse_configured: f64,
    /// Held-out RMSE with the identified value.
    pub rmse_identified: f64,
    /// The block t statistic of the gain (log RMSE ratios per block), and its critical value; for
    /// the drive's response (command latency, profile limits) that of the whole response,
    /// configured against identified.
    pub t: f64,
    /// See `t`.
    pub critical: f64,
    /// The identified value explains the held-out part significantly better: a cause.
    pub cause: bool,
}

/// What the loop gets wrong, for one DOF.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LoopReport {
    /// The DOF.
    pub dof: String,
    /// Every value identified.
    pub values: Vec<LoopValue>,
    /// What could not be identified, and why.
    pub notes: Vec<String>,
    /// The configured age of the drives' readings [s] (`can_feedback_latency_s`, else
    /// `can_latency_s`): kept when only the command latency changes.
    pub configured_can_feedback_s: f64,
    /// The configured position-loop gains `[kp, ki, kd]` of the joint's drives: a drive's
    /// `hal.sim.drive_gains` entry is written whole.
    #[serde(skip)]
    pub drive_gains: std::collections::BTreeMap<String, [f64; 3]>,
}

impl LoopReport {
    /// The causes: values the configuration has wrong.
    pub fn causes(&self) -> impl Iterator<Item = &LoopValue> {
        self.values.iter().filter(|v| v.cause)
    }

    /// The simulation's extension: `hal.sim` keys with the identified values of the causes.
    pub fn hal_sim(&self) -> serde_json::Map<String, serde_json::Value> {
        let mut out = serde_json::Map::new();
        for v in self.causes() {
            let path: Vec<&str> = v.key.trim_start_matches("hal.sim.").split('.').collect();
            match path.as_slice() {
                [k] => {
                    out.insert(k.to_string(), v.value.into());
                }
                [a, k] => {
                    let inner = out.entry(a.to_string()).or_insert_with(|| serde_json::json!({}));
                    inner[k] = v.value.into();
                }
                ["drive_gains", drive, "kp"] => {
                    let [_, ki, kd] = self.drive_gains.get(*drive).copied().unwrap_or([v.value, 0.0, 0.0]);
                    let gains = out.entry("drive_gains").or_insert_with(|| serde_json::json!({}));
                    gains[*drive] = serde_json::json!({"kp": v.value, "ki": ki, "kd": kd});
                }
                _ => {}
            }
        }
        // A named command latency goes with the feedback latencies it was fitted beside. Each is
        // estimated against the F/T torque, whose element effects lead it: the feedback
        // latencies come out late and the command latency, fitted on the drives' readings aged
        // by the CAN one, early by as much, so the loop's delays add up only when written
        // together (the shoulder's closed-loop replay, F/T torque RMSE over seven sessions: 4.8-5.1
        // Nm with C, 0.27-4.72 Nm with all three; with the command latency alone two of four
        // sessions got worse, 4.91 -> 5.93 and 4.79 -> 5.27 Nm, before the reversal mask).
        // Without an estimate the readings keep their configured age (it defaults to the
        // command latency: a new command latency alone must not age them too).
        if out.contains_key("can_latency_s") {
            for (name, key) in [("feedback_latency_can", "can_feedback_latency_s"), ("feedback_latency_spi", "spi_latency_s")] {
                if let Some(v) = self.values.iter().find(|v| v.name == name) {
                    out.insert(key.into(), v.value.into());
                }
            }
            out.entry("can_feedback_latency_s").or_insert(self.configured_can_feedback_s.into());
        }
        out
    }
}

fn err(m: impl Into<String>) -> ExperimentError {
    ExperimentError(m.into())
}

/// `dof`'s closed-loop signals in the recording `path`, wired by `loaded` (the joint's drives,
/// transmission and encoders).
pub fn read(path: &Path, loaded: &LoadedConfig, dof: &str) -> Result<LoopRecording, ExperimentError> {
    let cfg = &loaded.config;
    let joint = cfg.joints.iter().find(|j| j.dof_names().contains(&dof)).ok_or_else(|| err(format!("no joint `{dof}` in {}", loaded.source.file.display())))?;
    let sim = joint.sim.as_ref().ok_or_else(|| err(format!("joint `{}` has no `sim` section: its drives' transmission is unknown", joint.name)))?;
    let dofs: Vec<String> = joint.dof_names().iter().map(|s| s.to_string()).collect();
    let series = jointctl_record::reader::all_joint_series(path).map_err(|e| err(e.to_string()))?.0;
    let of = |name: &str| series.get(name).ok_or_else(|| err(format!("{}: no joint `{name}` recorded", path.display())));
    let main = of(dof)?;
    let raw = jointctl_record::reader::raw_samples(path).map_err(|e| err(e.to_string()))?;
    let by_cycle: std::collections::HashMap<u64, usize> = raw.iter().enumerate().map(|(i, r)| (r.cycle, i)).collect();
    let rows: Vec<(usize, usize)> = main.cycle.iter().enumerate().filter_map(|(i, c)| by_cycle.get(c).map(|&r| (i, r))).collect();
    if rows.len() < 100 {
        return Err(err(format!("{}: {} cycles with both joint state and raw readings; a closed-loop recording needs at least 100", path.display(), rows.len())));
    }
    let mut rec = LoopRecording { dof: dof.into(), ..Default::default() };
    rec.t_s = rows.iter().map(|&(i, _)| main.t_s[i]).collect();
    rec.sensor_torque_nm = rows.iter().map(|&(i, _)| main.sensor_torque_nm[i]).collect();
    // Every DOF's F/T torque loads the drives (M^T tau); a DOF without one is said to be unknown.
    let mut torques: Vec<Vec<f64>> = dofs.iter().map(|d| series.get(d).map_or(vec![f64::NAN; rows.len()], |s| rows.iter().map(|&(i, _)| s.sensor_torque_nm.get(i).copied().unwrap_or(f64::NAN)).collect())).collect();
    for ((d, tau), row) in dofs.iter().zip(&mut torques).zip(&sim.matrix) {
        if tau.iter().all(|x| x.is_nan()) {
            rec.unmeasured_dofs.push(d.clone());
            rec.unmeasured_rows.push((0..sim.drives.len()).map(|k| row.get(k).copied().unwrap_or(0.0)).collect());
            tau.iter_mut().for_each(|x| *x = 0.0);
        }
    }
    for (k, name) in sim.drives.iter().enumerate() {
        let mut elmo = cfg.hal.sim.elmo;
        if let Some(g) = cfg.hal.sim.drive_gains.get(name) {
            (elmo.kp, elmo.ki, elmo.kd) = (g.kp, g.ki, g.kd);
        }
        let mut d = DriveTrace { name: name.clone(), elmo, ..Default::default() };
        for (n, &(_, r)) in rows.iter().enumerate() {
            let reading = raw[r].drives.iter().find(|(x, ..)| x == name);
            d.position_rad.push(reading.map_or(f64::NAN, |(_, r, _)| this_cycles(&r.position_rad)));
            d.setpoint_rad.push(reading.map_or(f64::NAN, |(_, _, s)| *s));
            d.torque_nm.push(reading.map_or(f64::NAN, |(_, r, _)| this_cycles(&r.torque_nm)));
            d.load_nm.push(sim.matrix.iter().zip(&torques).map(|(row, tau)| row.get(k).copied().unwrap_or(0.0) * tau[n]).sum());
        }
        rec.drives.push(d);
    }
    for name in joint.encoders.values() {
        let values = rows.iter().map(|&(_, r)| raw[r].encoders.iter().find(|(x, _)| x == name).map_or(f64::NAN, |(_, v)| this_cycles(v))).collect();
        rec.encoders.push((name.clone(), values));
    }
    Ok(rec)
}

/// A reading's value when it came this cycle (valid), else NaN: a held (stale) value is an old
/// sample, not this cycle's state, and taken as one it would shift the fits' timing.
fn this_cycles(r: &jointctl_api::Reading) -> f64 {
    if r.status == jointctl_api::ReadingStatus::VALID { r.value } else { f64::NAN }
}

/// `x` at time `q` by linear interpolation of the samples (`t` rising); NaN outside or next to
/// an unknown sample.
fn at(t: &[f64], x: &[f64], q: f64) -> f64 {
    if t.is_empty() || q < t[0] || q > t[t.len() - 1] {
        return f64::NAN;
    }
    let i = t.partition_point(|s| *s <= q).clamp(1, t.len() - 1);
    let (t0, t1) = (t[i - 1], t[i]);
    let w = if t1 > t0 { (q - t0) / (t1 - t0) } else { 0.0 };
    x[i - 1] + w * (x[i] - x[i - 1])
}

/// The central-difference rate of `x` [unit/s]; NaN at the ends and next to unknown samples.
fn rate(t: &[f64], x: &[f64]) -> Vec<f64> {
    (0..x.len()).map(|i| if i == 0 || i + 1 == x.len() { f64::NAN } else { (x[i + 1] - x[i - 1]) / (t[i + 1] - t[i - 1]) }).collect()
}

fn rms_where(sq: &[f64], keep: impl Fn(usize) -> bool) -> f64 {
    let v: Vec<f64> = sq.iter().enumerate().filter(|(i, e)| keep(*i) && e.is_finite()).map(|(_, e)| *e).collect();
    if v.is_empty() { f64::NAN } else { (v.iter().sum::<f64>() / v.len() as f64).sqrt() }
}

/// Whether a signal moves: its spread is more than `counts` of a 14-bit encoder (section 2.2).
fn moves(x: &[f64]) -> bool {
    let (lo, hi) = x.iter().filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(*v), h.max(*v)));
    hi - lo > 8.0 * std::f64::consts::TAU / 16384.0
}

/// A drive replayed from the recorded set-points, each arriving `command_latency_s` after its
/// cycle, against the recorded load: its position at each cycle's time [rad].
///
/// ```
/// use jointctl_experiments::loop_causes::{DriveTrace, replay_drive};
/// // A set-point of 0.1 rad sent at t = 0, arriving 30 ms later; no load.
/// let t: Vec<f64> = (0..40).map(|k| k as f64 * 0.025).collect();
/// let d = DriveTrace { setpoint_rad: vec![0.1; 40], load_nm: vec![0.0; 40], ..Default::default() };
/// let p = replay_drive(&t, &d, d.elmo, 0.03, 0.0);
/// assert_eq!(p[1], 0.0, "not arrived yet at 25 ms");
/// assert!((p[39] - 0.1).abs() < 1e-3, "there after a second: {}", p[39]);
/// ```
pub fn replay_drive(t_s: &[f64], d: &DriveTrace, elmo: ElmoConfig, command_latency_s: f64, start_rad: f64) -> Vec<f64> {
    if t_s.is_empty() {
        return Vec::new();
    }
    let mut drive = ElmoDrive::new(elmo, start_rad);
    let load0 = d.load_nm.iter().copied().find(|l| l.is_finite()).unwrap_or(0.0);
    // Settle the PID under the first load (its integral) before the recording starts.
    for _ in 0..(1.0 / REPLAY_STEP_S) as usize {
        drive.step(load0, REPLAY_STEP_S);
    }
    let mut out = Vec::with_capacity(t_s.len());
    let (mut now, mut next) = (t_s[0], 0usize);
    let mut last_load = load0;
    for &t in t_s {
        while now < t - 1e-12 {
            while next < t_s.len() && t_s[next] + command_latency_s <= now + 1e-12 {
                drive.set_target(d.setpoint_rad[next]);
                next += 1;
            }
            let load = at(t_s, &d.load_nm, now);
            if load.is_finite() {
                last_load = load;
            }
            let h = REPLAY_STEP_S.min(t - now);
            drive.step(last_load, h);
            now += h;
        }
        out.push(drive.position);
    }
    out
}

/// What the loop gets wrong on one DOF's closed-loop recording, against `loaded`'s simulation.
pub fn identify_loop(rec: &LoopRecording, loaded: &LoadedConfig) -> LoopReport {
    let sim = &loaded.config.hal.sim;
    // The configured age of the drives' readings (it defaults to the command latency).
    let configured_age = sim.can_feedback_latency_s.unwrap_or(sim.can_latency_s);
    let mut report = LoopReport { dof: rec.dof.clone(), configured_can_feedback_s: configured_age, ..Default::default() };
    let split = split_time(&rec.t_s, 0.7);
    let t = &rec.t_s;
    let train = |i: usize| t[i] < split;
    let held = |i: usize| t[i] >= split;
    if rec.sensor_torque_nm.iter().filter(|x| x.is_finite()).count() < 100 {
        report.notes.push(format!("`{}` has no F/T torque in the recording: latencies are measured against it", rec.dof));
        return report;
    }
    // The held-out part's squared errors without and with: the block test of their ratio.
    let compare = |before: &[f64], after: &[f64]| {
        let keep: Vec<usize> = (0..t.len()).filter(|&i| held(i) && before[i].is_finite() && after[i].is_finite()).collect();
        log_ratio_block_test(&keep.iter().map(|&i| before[i]).collect::<Vec<_>>(), &keep.iter().map(|&i| after[i]).collect::<Vec<_>>())
    };
    let value = |name: &str, key: &str, identified: f64, configured: f64, sq: &dyn Fn(f64) -> Vec<f64>| {
        let (before, after) = (sq(configured), sq(identified));
        let test = compare(&before, &after);
        LoopValue {
            name: name.into(),
            key: key.into(),
            value: identified,
            configured,
            rmse_configured: rms_where(&before, held),
            rmse_identified: rms_where(&after, held),
            t: test.t,
            critical: test.critical,
            cause: test.significant() && (identified - configured).abs() > 1e-9,
        }
    };
    // The drives' readings (CAN).
    let moving: Vec<&DriveTrace> = rec.drives.iter().filter(|d| moves(&d.position_rad)).collect();
    let mut can_feedback = configured_age;
    if moving.is_empty() {
        report.notes.push("the joint's drives did not move: no CAN latency or drive response to identify".into());
    } else {
        let group: Vec<&[f64]> = moving.iter().map(|d| d.position_rad.as_slice()).collect();
        match feedback_latency(rec, &group, split) {
            Some((l, residuals)) => {
                can_feedback = l;
                report.values.push(value("feedback_latency_can", "hal.sim.can_feedback_latency_s", l, configured_age, &residuals));
            }
            None => report.notes.push("the drives' readings explain none of the F/T torque's rate: no CAN latency identified".into()),
        }
    }
    // The encoders (SPI): only those that move tell their age.
    let encoders: Vec<&[f64]> = rec.encoders.iter().filter(|(_, x)| moves(x)).map(|(_, x)| x.as_slice()).collect();
    if encoders.is_empty() {
        report.notes.push("the joint's encoders did not move (a clamped output): no SPI latency to identify".into());
    } else {
        match feedback_latency(rec, &encoders, split) {
            Some((l, residuals)) => report.values.push(value("feedback_latency_spi", "hal.sim.spi_latency_s", l, sim.spi_latency_s, &residuals)),
            None => report.notes.push("the encoders' readings explain none of the F/T torque's rate: no SPI latency identified".into()),
        }
    }
    let commanded: Vec<&DriveTrace> = moving.into_iter().filter(|d| d.setpoint_rad.iter().filter(|s| s.is_finite()).count() > 50).collect();
    if commanded.is_empty() {
        report.notes.push("no drive of the joint followed set-points: no command latency to identify".into());
        return report;
    }
    // The drives' response to the set-points: replayed against their load, from the F/T sensors
    // through the transmission and, for a DOF they move that has none, from their torque readings.
    let commanded: Vec<DriveTrace> = if rec.unmeasured_dofs.is_empty() {
        commanded.into_iter().cloned().collect()
    } else {
        let unmeasured = rec.unmeasured_dofs.join(", ");
        // The joint's drives that move the unmeasured DOFs, moving or not: each is one equation.
        let coupled: Vec<&DriveTrace> = rec.drives.iter().enumerate().filter(|(i, _)| rec.unmeasured_rows.iter().any(|r| r[*i] != 0.0)).map(|(_, d)| d).collect();
        // Assumption: nine in ten cycles with a torque reading.
        let read = |d: &&DriveTrace| d.torque_nm.iter().filter(|x| x.is_finite()).count() * 10 >= 9 * t.len();
        if let Some(d) = coupled.iter().find(|d| !read(d)) {
            report.notes.push(format!(
                "the joint's drives also move {unmeasured} whose torque is not measured (no F/T sensor), and drive `{}` reported no torque (its current: \
                 `rated_torque_nm` in its bus entry, 0x6077 mapped in its TPDO1): the drives' load is unknown, so no command latency, profile limits or \
                 position-loop gain are identified",
                d.name
            ));
            return report;
        }
        report.notes.push(format!(
            "the joint's drives also move {unmeasured} whose torque is not measured (no F/T sensor): its torque is taken from the drives' torque readings \
             (current) less the configured motor inertia and gear friction, averaged over {:.0} ms",
            load::AVERAGE_S * 1000.0
        ));
        let loads = load::with_unmeasured(t, &rec.drives, &rec.unmeasured_rows, can_feedback);
        rec.drives
            .iter()
            .zip(loads)
            .filter(|(d, _)| commanded.iter().any(|c| c.name == d.name))
            .map(|(d, load_nm)| DriveTrace { load_nm, ..d.clone() })
            .collect()
    };
    // Each drive's state: its reading taken `can_feedback` later.
    let truth_aged = |age_s: f64| -> Vec<Vec<f64>> { commanded.iter().map(|d| t.iter().map(|&q| at(t, &d.position_rad, q + age_s)).collect()).collect() };
    let truth = truth_aged(can_feedback);
    let squared_against = |truth: &[Vec<f64>], latency: f64, elmo_of: &dyn Fn(ElmoConfig) -> ElmoConfig| -> Vec<f64> {
        let mut sq = vec![0.0; t.len()];
        for (d, truth) in commanded.iter().zip(truth) {
            let start = truth.iter().copied().find(|x| x.is_finite()).unwrap_or(0.0);
            let model = replay_drive(t, d, elmo_of(d.elmo), latency, start);
            for i in 0..t.len() {
                sq[i] += (model[i] - truth[i]).powi(2);
            }
        }
        sq
    };
    let squared = |latency: f64, elmo_of: &dyn Fn(ElmoConfig) -> ElmoConfig| squared_against(&truth, latency, elmo_of);
    // Latency and profile limits trade off (a slower profile looks like a later set-point) along
    // a narrow valley: a grid over latency and acceleration limit finds the valley (at the
    // configured position-loop stiffness; the search below adds it as a factor on the drives'
    // configured kp).
    let limit = |a: f64, v: f64, kp: f64| move |e: ElmoConfig| ElmoConfig { max_acceleration_rad_s2: a, max_velocity_rad_s: v, kp: e.kp * kp, ..e };
    let score = |l: f64, a: f64, v: f64, kp: f64| block_rms_where(&squared(l.clamp(0.0, MAX_LATENCY_S), &limit(a, v, kp)), train);
    let (a0, v0) = (sim.elmo.max_acceleration_rad_s2, sim.elmo.max_velocity_rad_s);
    let mut start = (f64::INFINITY, [sim.can_latency_s, a0.log10(), v0.log10(), 0.0]);
    for k in 0..=40 {
        for j in 0..=ACCEL_GRID {
            let (l, la) = (MAX_LATENCY_S * k as f64 / 40.0, -0.5 + 4.0 * j as f64 / ACCEL_GRID as f64);
            let s = score(l, 10f64.powf(la), v0, 1.0);
            if s < start.0 {
                start = (s, [l, la, v0.log10(), 0.0]);
            }
        }
    }
    // Stiffness and latency trade off too (a softer loop lags like a later set-point), along a
    // valley too narrow for the simplex alone (from the grid's stiffness it stalled at the
    // search's bound: the shoulder's kp 31.6x for 0.25x). Each of several stiffness factors gets
    // its best latency at the grid's acceleration limit; from the best of them, searches along
    // one value at a time close in on the valley's floor, and the simplex follows it.
    let whole_fit = |x: [f64; 4]| score(x[0], 10f64.powf(x[1]), 10f64.powf(x[2]), 10f64.powf(x[3]));
    let [_, la, lv, _] = start.1;
    let mut best = KP_STARTS
        .iter()
        .map(|&lk| {
            let l = search(0.0, MAX_LATENCY_S, 0.0005, |l| whole_fit([l, la, lv, lk]));
            (whole_fit([l, la, lv, lk]), [l, la, lv, lk])
        })
        .fold((f64::INFINITY, start.1), |b, x| if x.0 < b.0 { x } else { b })
        .1;
    for _ in 0..3 {
        // (value's index, half-width, step): latency [s], then log10 of kp's factor and of the
        // acceleration limit.
        for (k, half, step) in [(0, 0.005, 0.00025), (3, 0.25, 0.01), (1, 0.2, 0.01)] {
            let x0 = best[k];
            let (lo, hi) = match k {
                0 => (0.0, MAX_LATENCY_S),
                3 => (-KP_DECADES, KP_DECADES),
                _ => (f64::NEG_INFINITY, f64::INFINITY),
            };
            best[k] = search((x0 - half).max(lo), (x0 + half).min(hi), step, |x| {
                let mut y = best;
                y[k] = x;
                whole_fit(y)
            });
        }
    }
    let best = nelder_mead(whole_fit, best, [0.001, 0.05, 0.3, 0.05], 300);
    let (mut latency, a, v) = (best[0].clamp(0.0, MAX_LATENCY_S), 10f64.powf(best[1]), 10f64.powf(best[2]));
    let kp = 10f64.powf(best[3].clamp(-KP_DECADES, KP_DECADES));
    // A limit the recording never reached is not identified: without it the fit is as good.
    let reached = |with: f64, without: f64| with < (1.0 - LIMIT_EVIDENCE) * without;
    let a_reached = reached(score(latency, a, v, kp), score(latency, 1e9, v, kp));
    let v_reached = reached(score(latency, a, v, kp), score(latency, a, 1e9, kp));
    if !a_reached || !v_reached {
        let (a1, v1) = (if a_reached { a } else { a0 }, if v_reached { v } else { v0 });
        latency = search(0.0, MAX_LATENCY_S, 0.0005, |l| score(l, a1, v1, kp));
    }
    let (a_used, v_used) = (if a_reached { a } else { a0 }, if v_reached { v } else { v0 });
    // The drive's response is one model: its evidence is tested as a whole (configured against
    // identified, on the held-out part), because a profile limit shows only at the few steps
    // that reach it, and a test of it alone would be drowned by the blocks between them. A
    // part of it is then named when putting its configured value back makes the training fit
    // clearly worse.
    let identified = squared(latency, &limit(a_used, v_used, kp));
    // The configured loop whole: its command latency and limits against the readings aged as
    // configured (not by the estimate, whose bias the identified command latency takes up: a
    // clean shoulder session's command latency was named 21.5 ms for 30).
    let as_configured = squared_against(&truth_aged(configured_age), sim.can_latency_s, &limit(a0, v0, 1.0));
    let whole = compare(&as_configured, &identified);
    let trained = block_rms_where(&identified, train);
    // `told`: the data determine this part at all (see the position loop's below).
    let mut part = |name: &str, key: &str, ident: f64, configured: f64, without: &[f64], told: bool| {
        let needed = block_rms_where(without, train) > (1.0 + LIMIT_EVIDENCE) * trained;
        report.values.push(LoopValue {
            name: name.into(),
            key: key.into(),
            value: ident,
            configured,
            rmse_configured: rms_where(without, held),
            rmse_identified: rms_where(&identified, held),
            t: whole.t,
            critical: whole.critical,
            cause: told && whole.significant() && needed && (ident - configured).abs() > 1e-9 * configured.abs().max(1.0),
        });
    };
    part("command_latency", "hal.sim.can_latency_s", latency, sim.can_latency_s, &squared(sim.can_latency_s, &limit(a_used, v_used, kp)), true);
    if a_reached {
        part("drive_max_acceleration", "hal.sim.elmo.max_acceleration_rad_s2", a, a0, &squared(latency, &limit(a0, v_used, kp)), true);
    } else {
        report.notes.push(format!("the drives' acceleration limit was not reached in this recording (no limit explains it as well): the configured {a0} rad/s^2 stays"));
    }
    if v_reached {
        part("drive_max_velocity", "hal.sim.elmo.max_velocity_rad_s", v, v0, &squared(latency, &limit(a_used, v0, kp)), true);
    } else {
        report.notes.push(format!("the drives' velocity limit was not reached in this recording (no limit explains it as well): the configured {v0} rad/s stays"));
    }
    // The position loop: one stiffness factor for the joint's drives, reported per drive (its
    // own gains, `hal.sim.drive_gains`, so that the arm's other drives keep theirs).
    let without_kp = squared(latency, &limit(a_used, v_used, 1.0));
    // Told only when the fit is clearly worse with the configured kp and with half and twice the
    // factor found, each with its own best latency (they trade off): a flat profile, as a load
    // known from currents gives, would name a kp anywhere in it (the shoulder: 27000 Nm/rad
    // named for 1000).
    let profile = |f: f64| {
        let k = (kp * f).clamp(10f64.powf(-KP_DECADES), 10f64.powf(KP_DECADES));
        let l = search(0.0, MAX_LATENCY_S, 0.0005, |l| score(l, a_used, v_used, k));
        score(l, a_used, v_used, k)
    };
    let fits = [profile(1.0 / kp), profile(0.5), profile(2.0)];
    let kp_told = fits.iter().all(|f| *f > (1.0 + LIMIT_EVIDENCE) * trained);
    if !kp_told {
        report.notes.push(format!(
            "the drives' position-loop stiffness is not told by this recording: the configured kp, or half or twice the best factor ({kp:.3}x) with \
             its best latency, explains the training part's drive motion within {:.0} % ({:.2e}, {:.2e}, {:.2e} against {:.2e} rad), so the \
             configured gains stay",
            LIMIT_EVIDENCE * 100.0,
            fits[0],
            fits[1],
            fits[2],
            trained
        ));
    }
    for d in &commanded {
        let key = format!("hal.sim.drive_gains.{}.kp", d.name);
        part("drive_kp", &key, d.elmo.kp * kp, d.elmo.kp, &without_kp, kp_told);
        report.drive_gains.insert(d.name.clone(), [d.elmo.kp, d.elmo.ki, d.elmo.kd]);
    }
    report
}

#[cfg(test)]
mod tests;
