//! `jointctl cmd experiment`: an experiment file (`experiment.yaml`, as `jointctl identify`
//! proposes it for a confounded pair) run on a running arm, in torque control.
//!
//! The thesis characterises a joint by deflecting it while the drives hold (section 3.3.1), and
//! controls its torque with the output fixed (chapter 4). On an arm whose output is fixed the
//! deflection follows the torque through the spring, so each segment's deflection sine is run as
//! a torque sine (figure 4.6's loop) of the joint's stiffness times its amplitude, at its
//! frequency, from rest. `jointctl record` beside it records what `jointctl identify` reads.

use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use jointctl_ident::identify::experiment::Segment;
use jointctl_ipc::{CommandClient, CommandRequest, FieldMask, TorqueWaveform};

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

/// Runs `file` on `joint`; `stiffness`: the one to turn deflections into torques, else the
/// joint's published stiffness. `dry_run`: print the plan, send nothing.
pub fn run(args: &CmdArgs, joint: &str, file: &Path, stiffness: Option<f64>, dry_run: bool) -> ExitCode {
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
        eprintln!("  {}: torque sine {:.4} Nm at {:.4} Hz for {:.2} s (deflection {:.5} rad), then {REST_S} s at 0 Nm", i + 1, s.amplitude_nm, s.frequency_hz, s.duration_s, experiment.segments[i].amplitude_rad);
    }
    if dry_run {
        return ExitCode::SUCCESS;
    }
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        if let Err(e) = crate::arm_view::signal_hook_register(signal, &stop) {
            return crate::fail(format!("cannot install the signal handlers: {e}"));
        }
    }
    let client = match CommandClient::open(&super::scope(args), &args.arm, &format!("jointctl-experiment-{}", std::process::id())) {
        Ok(c) => c,
        Err(e) => return crate::fail_err(e),
    };
    let send = |waveform: TorqueWaveform, amplitude_nm: f64, frequency_hz: f64| -> Result<(), String> {
        let request = CommandRequest::torque(joint, waveform, &[amplitude_nm, frequency_hz, 0.0, 0.0]);
        match client.send(request, args.timeout) {
            Ok(r) if r.accepted != 0 => Ok(()),
            Ok(r) => Err(format!("refused: {}", r.text())),
            Err(e) => Err(e.to_string()),
        }
    };
    // Zero torque, or when even that is not answered, hold; the error says what the joint does.
    let zero = || {
        send(TorqueWaveform::STEP, 0.0, 0.0).map_err(|e| match client.send(CommandRequest::new(jointctl_ipc::CommandKind::HOLD, joint, &[]), args.timeout) {
            Ok(r) if r.accepted != 0 => format!("{e}; {joint} was told to hold instead"),
            _ => format!("{e}; hold refused or unanswered too: {joint} may still follow the sine, stop it with `jointctl cmd hold {joint}` or `jointctl cmd stop`"),
        })
    };
    let wait = |seconds: f64| -> bool {
        let until = Instant::now() + Duration::from_secs_f64(seconds);
        while Instant::now() < until {
            if stop.load(Ordering::Relaxed) {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20).min(until.saturating_duration_since(Instant::now())));
        }
        true
    };
    for (i, s) in plan.iter().enumerate() {
        eprintln!("segment {}/{}: {:.4} Nm at {:.4} Hz", i + 1, plan.len(), s.amplitude_nm, s.frequency_hz);
        if let Err(e) = send(TorqueWaveform::SINE, s.amplitude_nm, s.frequency_hz) {
            // Unanswered, it may have been applied: zero it either way.
            let after = zero().err().map_or(format!("{joint} follows a zero torque reference"), |z| format!("the zero torque after it: {z}"));
            return crate::fail(format!("segment {}: {e}; {after}", i + 1));
        }
        let finished = wait(s.duration_s);
        if let Err(e) = zero() {
            return crate::fail(format!("segment {}: the zero torque after it: {e}", i + 1));
        }
        if !finished || !wait(REST_S) {
            return crate::fail(format!("stopped by a signal in segment {}: {joint} follows a zero torque reference", i + 1));
        }
    }
    outln!("done: {} segments run on {joint}; it follows a zero torque reference", plan.len());
    ExitCode::SUCCESS
}

/// The joint's stiffness as its runtime publishes it (a VSA's at its pivot setting now).
fn published_stiffness(args: &CmdArgs, joint: &str) -> Result<f64, String> {
    let state = crate::arm_view::newest(&args.arm, args.domain.clone(), args.ipc_root.clone(), args.timeout, |n| n.joint_state.clone(), jointctl_ipc::joint_state_service)?;
    let sample = state.joints().iter().find(|j| jointctl_ipc::decode_name(&j.name) == joint).ok_or_else(|| {
        let names: Vec<&str> = state.joints().iter().map(|j| jointctl_ipc::decode_name(&j.name)).collect();
        format!("arm `{}` has no joint `{joint}` (it has {})", args.arm, names.join(", "))
    })?;
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
}
