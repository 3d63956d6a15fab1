//! `jointctl cmd experiment`: an experiment file (`experiment.yaml`, as `jointctl identify`
//! proposes it for a confounded pair) run on a running arm, in torque control or, with
//! `--position`, by position.
//!
//! The thesis characterises a joint by deflecting it while the drives hold (section 3.3.1), and
//! controls its torque with the output fixed (chapter 4). On an arm whose output is fixed the
//! deflection follows the torque through the spring, so each segment's deflection sine is run as
//! a torque sine (figure 4.6's loop) of the joint's stiffness times its amplitude, at its
//! frequency, from rest. `jointctl record` beside it records what `jointctl identify` reads.
//!
//! `--position` runs the same file on a set-up that deflects the element by position instead
//! (section 3.3.1's characterisation, the joint deflected while its drives hold the motors at
//! zero, with a rig's joint in place of the hand): each segment a position sine of the named
//! joint about where it stands, sent as trajectories (`cmd trajectory`'s command, at most 64
//! points each; [`position_plan`]).

use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use jointctl_ident::identify::experiment::Segment;
use jointctl_ipc::{CommandClient, CommandKind, CommandRequest, FieldMask, MAX_COMMAND_POINTS, TorqueWaveform};

use super::CmdArgs;

/// Zero torque between two segments, so that each starts from rest [s] (as `sim record` leaves
/// a second between them).
pub const REST_S: f64 = 1.0;

/// One segment as it is sent: the torque sine and how long it runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorqueSegment {
    /// Amplitude of the torque sine [Nm].
    pub amplitude_nm: f64,
    /// [Hz]
    pub frequency_hz: f64,
    /// Whole periods, at least the segment's duration [s]: a sine stopped there is near zero.
    /// Not at it: the sine starts at the cycle after its command is accepted and the zero at the
    /// cycle after its own, so the two can be up to one loop period apart (at 40 Hz and 1 Hz, a
    /// step of up to 16 % of the amplitude).
    pub duration_s: f64,
}

/// The torque sines of `segments` for a joint of stiffness `stiffness_nm_per_rad`.
pub fn torque_segments(segments: &[Segment], stiffness_nm_per_rad: f64) -> Vec<TorqueSegment> {
    segments
        .iter()
        .map(|s| TorqueSegment {
            amplitude_nm: stiffness_nm_per_rad * s.amplitude_rad,
            frequency_hz: s.frequency_hz,
            duration_s: (s.duration_s * s.frequency_hz - 1e-9).ceil().max(1.0) / s.frequency_hz,
        })
        .collect()
}

/// Most periods one segment runs in the position form: its points are held while it runs
/// (24 bytes each, eight a period: 19 MB at this bound), and an experiment `identify` proposes
/// runs minutes, not days.
pub const MAX_POSITION_PERIODS: usize = 100_000;

/// Sine points per period in the position form: every eighth of a period, with the sine's own
/// velocity. The cubic Hermite the trajectory mode draws between them stays within 0.1 % of the
/// sine's amplitude (its error bound, `h^4 max|f''''| / 384` with `h` an eighth of the period,
/// is `(2 pi / 8)^4 / 384 = 9.9e-4` of the amplitude).
pub const POINTS_PER_PERIOD: usize = 8;
// The peaks fall on points only when a period holds a multiple of 4 of them.
const _: () = assert!(POINTS_PER_PERIOD.is_multiple_of(4));

/// One segment in the position form: the trajectories to send one after the other, each of at
/// most `max_points` (time from its own start [s], position [rad], velocity [rad/s]) and each
/// ending where the joint stands still, so that the next one, sent when it ends, begins where
/// it left off.
#[derive(Clone, Debug, PartialEq)]
pub struct PositionSegment {
    /// The trajectories, in order.
    pub trajectories: Vec<Vec<[f64; 3]>>,
    /// Whole periods of the sine (the segment's duration rounded up, at least one).
    pub periods: usize,
    /// From the first point to the last [s].
    pub duration_s: f64,
}

/// The position form of `segment` about `center_rad`: `center + A sin(2 pi f t)` for whole
/// periods, a quarter period more to the peak, then back to `center` in half a period with no
/// jump in velocity (a cubic from rest to rest). The trajectories are cut at the sine's peaks,
/// where the joint stands still: a next trajectory that starts late holds the peak for that
/// long instead of jumping. `max_points` is taken as at least 5 (one half period).
pub fn position_plan(segment: &Segment, center_rad: f64, max_points: usize) -> PositionSegment {
    let (a, f) = (segment.amplitude_rad, segment.frequency_hz);
    let periods = (segment.duration_s * f - 1e-9).ceil().max(1.0) as usize;
    let omega = 2.0 * std::f64::consts::PI * f;
    let step_s = 1.0 / (f * POINTS_PER_PERIOD as f64);
    let (half, quarter) = (POINTS_PER_PERIOD / 2, POINTS_PER_PERIOD / 4);
    let is_peak = |k: usize| k % half == quarter;
    // Phases k pi/4 up to the peak a quarter period after the last whole one.
    let last = POINTS_PER_PERIOD * periods + quarter;
    let mut points: Vec<[f64; 3]> = (0..=last)
        .map(|k| {
            let t = k as f64 * step_s;
            // At the peaks the sine's velocity is zero, not its rounding.
            let v = if is_peak(k) { 0.0 } else { a * omega * (omega * t).cos() };
            [t, center_rad + a * (omega * t).sin(), v]
        })
        .collect();
    let end_s = points[last][0] + 0.5 / f;
    points.push([end_s, center_rad, 0.0]);
    let max_points = max_points.max(half + 1);
    let mut trajectories = Vec::new();
    let mut start = 0;
    while start < points.len() - 1 {
        // The farthest point this trajectory may end at: a peak, or the last point.
        let end = (start + 1..points.len()).filter(|&i| i - start < max_points && (is_peak(i) || i == points.len() - 1)).max().unwrap_or(points.len() - 1);
        let t0 = points[start][0];
        trajectories.push(points[start..=end].iter().map(|p| [p[0] - t0, p[1], p[2]]).collect());
        start = end;
    }
    PositionSegment { trajectories, periods, duration_s: end_s }
}

/// Runs `file` on `joint`; `stiffness`: the one to turn deflections into torques, else the
/// joint's published stiffness; `position`: as position sines instead ([`position_plan`]).
/// `dry_run`: print the plan, send nothing.
pub fn run(args: &CmdArgs, joint: &str, file: &Path, stiffness: Option<f64>, position: bool, dry_run: bool) -> ExitCode {
    if args.zenoh.is_some() {
        return crate::fail("cmd experiment runs on the arm's machine (shared memory), not over --zenoh: a network lost mid-run would leave a segment running");
    }
    if args.stream {
        return crate::fail("cmd experiment sends each segment once, not streamed (a renewed sine would start again): leave out --stream");
    }
    let experiment = match crate::experiment::read_experiment(file) {
        Ok(e) => e,
        Err(e) => return crate::fail(e),
    };
    if position {
        return run_position(args, joint, file, &experiment.segments, dry_run);
    }
    let k = match stiffness {
        Some(k) if k.is_finite() && k > 0.0 => k,
        Some(k) => return crate::fail(format!("--stiffness: {k} Nm/rad must be positive")),
        None => match published_stiffness(args, joint) {
            Ok(k) => k,
            Err(e) => return crate::fail(e),
        },
    };
    let plan = torque_segments(&experiment.segments, k);
    if let Some((i, s)) = plan.iter().enumerate().find(|(_, s)| !s.duration_s.is_finite() || s.duration_s > 86_400.0) {
        return crate::fail(format!("{}: segments[{i}]: {:.3e} Hz needs {:.3e} s for one whole period, more than a day", file.display(), s.frequency_hz, s.duration_s));
    }
    let total: f64 = plan.iter().map(|s| s.duration_s + REST_S).sum();
    eprintln!("{}: {} segments on {joint}, {k:.3} Nm/rad, {total:.0} s", file.display(), plan.len());
    for (i, s) in plan.iter().enumerate() {
        let segment = &experiment.segments[i];
        eprintln!("  {}: torque sine {:.4} Nm at {:.4} Hz for {:.2} s (deflection {:.5} rad, peak rate {:.3} rad/s), then {REST_S} s at 0 Nm", i + 1, s.amplitude_nm, s.frequency_hz, s.duration_s, segment.amplitude_rad, segment.peak_rate_rad_per_s());
    }
    if dry_run {
        return ExitCode::SUCCESS;
    }
    let Some(session) = Session::open(args, "experiment") else { return ExitCode::FAILURE };
    let send = |waveform: TorqueWaveform, amplitude_nm: f64, frequency_hz: f64| session.send(CommandRequest::torque(joint, waveform, &[amplitude_nm, frequency_hz, 0.0, 0.0]));
    // Zero torque, or when even that is not answered, hold; the error says what the joint does.
    let zero = || {
        send(TorqueWaveform::STEP, 0.0, 0.0).map_err(|e| match session.hold(joint) {
            Ok(()) => format!("{e}; {joint} was told to hold instead"),
            Err(_) => format!("{e}; hold refused or unanswered too: {joint} may still follow the sine, stop it with `jointctl cmd hold {joint}` or `jointctl cmd stop`"),
        })
    };
    for (i, s) in plan.iter().enumerate() {
        eprintln!("segment {}/{}: {:.4} Nm at {:.4} Hz", i + 1, plan.len(), s.amplitude_nm, s.frequency_hz);
        if let Err(e) = send(TorqueWaveform::SINE, s.amplitude_nm, s.frequency_hz) {
            // Unanswered, it may have been applied: zero it either way.
            let after = zero().err().map_or(format!("{joint} follows a zero torque reference"), |z| format!("the zero torque after it: {z}"));
            return crate::fail(format!("segment {}: {e}; {after}", i + 1));
        }
        let finished = session.wait(s.duration_s);
        if let Err(e) = zero() {
            return crate::fail(format!("segment {}: the zero torque after it: {e}", i + 1));
        }
        if !finished || !session.wait(REST_S) {
            return crate::fail(format!("stopped by a signal in segment {}: {joint} follows a zero torque reference", i + 1));
        }
    }
    outln!("done: {} segments run on {joint}; it follows a zero torque reference", plan.len());
    ExitCode::SUCCESS
}

/// The position form ([`position_plan`]): each segment's trajectories sent one after the other,
/// each when the one before has run, about the position the joint stands at when it starts.
fn run_position(args: &CmdArgs, joint: &str, file: &Path, segments: &[Segment], dry_run: bool) -> ExitCode {
    if let Some((i, s)) = segments.iter().enumerate().find(|(_, s)| (s.duration_s * s.frequency_hz).ceil() > MAX_POSITION_PERIODS as f64) {
        return crate::fail(format!("{}: segments[{i}]: {:.0} periods; the position form runs at most {MAX_POSITION_PERIODS} a segment: shorten or split it", file.display(), (s.duration_s * s.frequency_hz).ceil()));
    }
    let total: f64 = segments.iter().map(|s| ((s.duration_s * s.frequency_hz - 1e-9).ceil().max(1.0) + 0.75) / s.frequency_hz + REST_S).sum();
    eprintln!("{}: {} segments on {joint} by position, about where it stands, {total:.0} s", file.display(), segments.len());
    for (i, s) in segments.iter().enumerate() {
        let p = position_plan(s, 0.0, MAX_COMMAND_POINTS);
        let count = p.trajectories.len();
        eprintln!(
            "  {}: position sine {:.5} rad at {:.4} Hz for {} periods and a quarter, back in {:.2} s ({:.2} s, {count} {}; peak rate {:.3} rad/s), then {REST_S} s held",
            i + 1,
            s.amplitude_rad,
            s.frequency_hz,
            p.periods,
            0.5 / s.frequency_hz,
            p.duration_s,
            if count == 1 { "trajectory" } else { "trajectories" },
            s.peak_rate_rad_per_s(),
        );
    }
    eprintln!("(a sine faster than the joint's set-point rate limit, controller.max_setpoint_rate_rad_s or its velocity limit, is clipped by the runtime and counted as rate_limited)");
    if dry_run {
        return ExitCode::SUCCESS;
    }
    let center_rad = match published_sample(args, joint).and_then(|s| s.get(FieldMask::POSITION, s.position_rad).ok_or_else(|| format!("joint `{joint}` publishes no position now: the sines are run about it"))) {
        Ok(q) => q,
        Err(e) => return crate::fail(e),
    };
    let Some(session) = Session::open(args, "experiment") else { return ExitCode::FAILURE };
    let hold = |e: String| match session.hold(joint) {
        Ok(()) => format!("{e}; {joint} was told to hold where it is"),
        Err(h) => format!("{e}; the hold after it: {h}: stop it with `jointctl cmd hold {joint}` or `jointctl cmd stop`"),
    };
    eprintln!("about {center_rad:.5} rad");
    for (i, s) in segments.iter().enumerate() {
        let plan = position_plan(s, center_rad, MAX_COMMAND_POINTS);
        eprintln!("segment {}/{}: {:.5} rad at {:.4} Hz", i + 1, segments.len(), s.amplitude_rad, s.frequency_hz);
        for chunk in &plan.trajectories {
            let mut request = CommandRequest::new(CommandKind::TRAJECTORY, joint, &[]);
            request.point_count = chunk.len() as u32;
            request.points[..chunk.len()].copy_from_slice(chunk);
            if let Err(e) = session.send(request) {
                return crate::fail(hold(format!("segment {}: {e}", i + 1)));
            }
            if !session.wait(chunk[chunk.len() - 1][0]) {
                return crate::fail(hold(format!("stopped by a signal in segment {}", i + 1)));
            }
        }
        if !session.wait(REST_S) {
            return crate::fail(hold(format!("stopped by a signal after segment {}", i + 1)));
        }
    }
    outln!("done: {} segments run on {joint} by position; it holds {center_rad:.5} rad, where it started", segments.len());
    ExitCode::SUCCESS
}

/// A command client with a stop flag that SIGINT and SIGTERM set.
struct Session<'a> {
    args: &'a CmdArgs,
    client: CommandClient,
    stop: Arc<AtomicBool>,
}

impl<'a> Session<'a> {
    /// Opens it; on failure the error is printed and None returned.
    fn open(args: &'a CmdArgs, what: &str) -> Option<Self> {
        let stop = Arc::new(AtomicBool::new(false));
        for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            if let Err(e) = crate::arm_view::signal_hook_register(signal, &stop) {
                crate::fail(format!("cannot install the signal handlers: {e}"));
                return None;
            }
        }
        match CommandClient::open(&super::scope(args), &args.arm, &format!("jointctl-{what}-{}", std::process::id())) {
            Ok(client) => Some(Session { args, client, stop }),
            Err(e) => {
                crate::fail_err(e);
                None
            }
        }
    }

    /// Sends `request`: Ok when accepted.
    fn send(&self, request: CommandRequest) -> Result<(), String> {
        match self.client.send(request, self.args.timeout) {
            Ok(r) if r.accepted != 0 => Ok(()),
            Ok(r) => Err(format!("refused: {}", r.text())),
            Err(e) => Err(e.to_string()),
        }
    }

    /// Tells `joint` to hold where it is.
    fn hold(&self, joint: &str) -> Result<(), String> {
        self.send(CommandRequest::new(CommandKind::HOLD, joint, &[]))
    }

    /// Waits `seconds`; false when a signal came first.
    fn wait(&self, seconds: f64) -> bool {
        let until = Instant::now() + Duration::from_secs_f64(seconds);
        while Instant::now() < until {
            if self.stop.load(Ordering::Relaxed) {
                return false;
            }
            std::thread::sleep(Duration::from_millis(5).min(until.saturating_duration_since(Instant::now())));
        }
        true
    }
}

/// The joint's newest published sample.
fn published_sample(args: &CmdArgs, joint: &str) -> Result<jointctl_ipc::JointSample, String> {
    let state: jointctl_ipc::ArmState = crate::arm_view::newest(&args.arm, args.domain.clone(), args.ipc_root.clone(), args.timeout, |n| n.joint_state.clone(), jointctl_ipc::joint_state_service)?;
    state.joints().iter().find(|j| jointctl_ipc::decode_name(&j.name) == joint).copied().ok_or_else(|| {
        let names: Vec<&str> = state.joints().iter().map(|j| jointctl_ipc::decode_name(&j.name)).collect();
        format!("arm `{}` has no joint `{joint}` (it has {})", args.arm, names.join(", "))
    })
}

/// The joint's stiffness as its runtime publishes it (a VSA's at its pivot setting now).
fn published_stiffness(args: &CmdArgs, joint: &str) -> Result<f64, String> {
    let sample = published_sample(args, joint)?;
    match sample.get(FieldMask::STIFFNESS, sample.stiffness_nm_per_rad) {
        Some(k) if k.is_finite() && k > 0.0 => Ok(k),
        _ => Err(format!("joint `{joint}` publishes no stiffness now: give --stiffness NM_PER_RAD")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_becomes_a_torque_sine_of_whole_periods() {
        let segments = [
            Segment { amplitude_rad: 0.01, frequency_hz: 0.25, duration_s: 20.0 },
            Segment { amplitude_rad: 0.02, frequency_hz: 0.3, duration_s: 20.0 },
            Segment { amplitude_rad: 0.005, frequency_hz: 2.0, duration_s: 0.1 },
        ];
        let s = torque_segments(&segments, 100.0);
        assert_eq!((s[0].amplitude_nm, s[0].frequency_hz, s[0].duration_s), (1.0, 0.25, 20.0));
        // 6 periods of 0.3 Hz are 20 s: no seventh for a rounding error.
        assert!((s[1].duration_s - 20.0).abs() < 1e-9 && (s[1].amplitude_nm - 2.0).abs() < 1e-12, "{:?}", s[1]);
        // Never less than one period.
        assert_eq!(s[2].duration_s, 0.5);
        let s = torque_segments(&[Segment { amplitude_rad: 0.01, frequency_hz: 0.33, duration_s: 20.0 }], 50.0);
        assert!((s[0].duration_s - 7.0 / 0.33).abs() < 1e-9, "{:?}", s[0]);
    }

    /// The position form sampled as the trajectory mode draws it, trajectory after trajectory
    /// with no gap: the sine within 0.1 % of its amplitude, the peaks and the return at rest.
    #[test]
    fn a_position_segment_is_its_sine_drawn_in_trajectories_cut_at_its_peaks() {
        use jointctl_modes::{Trajectory, TrajectoryPoint};
        for (a, f, seconds, chunks) in [(0.01, 1.0, 20.0, 3), (0.02, 0.25, 20.0, 1), (0.005, 3.0, 1.0, 1), (0.01, 2.0, 60.0, 16)] {
            let (center, omega) = (0.3, 2.0 * std::f64::consts::PI * f);
            let plan = position_plan(&Segment { amplitude_rad: a, frequency_hz: f, duration_s: seconds }, center, MAX_COMMAND_POINTS);
            assert_eq!(plan.periods, (seconds * f).round() as usize);
            assert_eq!(plan.trajectories.len(), chunks, "{a} rad at {f} Hz");
            let sine_end = (plan.periods as f64 + 0.25) / f;
            assert!((plan.duration_s - sine_end - 0.5 / f).abs() < 1e-9);
            let (mut t0, mut worst, mut last_q) = (0.0, 0.0_f64, center);
            for chunk in &plan.trajectories {
                assert!(chunk.len() <= MAX_COMMAND_POINTS && chunk[0][0] == 0.0, "{chunk:?}");
                // Each begins where the one before ended, and ends at rest.
                assert!((chunk[0][1] - last_q).abs() < 1e-12 && chunk[chunk.len() - 1][2] == 0.0);
                let points: Vec<TrajectoryPoint> = chunk.iter().map(|p| TrajectoryPoint { time_s: p[0], position_rad: p[1], velocity_rad_s: p[2] }).collect();
                let trajectory = Trajectory::new(&points).unwrap();
                let steps = (trajectory.duration_s() * 1000.0) as usize;
                for k in 0..=steps {
                    let t = k as f64 / 1000.0;
                    let (q, _) = trajectory.sample(t);
                    if t0 + t <= sine_end {
                        worst = worst.max((q - center - a * (omega * (t0 + t)).sin()).abs());
                    } else {
                        // The way back stays between the peak and the start.
                        assert!(q <= center + a + 1e-12 && q >= center - 1e-12, "{q} on the way back");
                    }
                }
                t0 += trajectory.duration_s();
                last_q = chunk[chunk.len() - 1][1];
            }
            assert!(worst < 1e-3 * a, "{worst} rad off a {a} rad sine at {f} Hz");
            assert!((last_q - center).abs() < 1e-15, "it ends where it began");
        }
    }
}
