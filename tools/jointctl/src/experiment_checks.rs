//! What `sim record` and `experiment torque-tracking` check of their options before they run:
//! a request the simulator cannot run or the arm cannot take is an error that names the option,
//! never a panic, an empty file or a run at some other setting.

use jointctl_ident::identify::experiment::Segment;

/// Whether a sine of the flow source is one the simulator can run: its amplitude in (0, pi]
/// rad, its frequency in [0.001, 100] Hz (at least a thousandth of a hertz, a period of 1000 s:
/// slower is no characterisation, and far slower, below about 4e-18 Hz, a whole period
/// overflows what a wait can hold), its duration in (0, 86400] s; `field` names a field where
/// the error says which.
pub(crate) fn check_segment(s: &Segment, field: impl Fn(&str) -> String) -> Result<(), String> {
    let bad = |name: &str, value: f64, rule: &str| Err(format!("{}: {} must be {rule}", field(name), shown(value)));
    if !(s.amplitude_rad.is_finite() && s.amplitude_rad > 0.0 && s.amplitude_rad <= std::f64::consts::PI) {
        return bad("amplitude_rad", s.amplitude_rad, "in (0, pi] rad");
    }
    if !(s.frequency_hz.is_finite() && s.frequency_hz >= 1e-3 && s.frequency_hz <= jointctl_ident::identify::experiment::MAX_FREQUENCY_HZ) {
        return bad("frequency_hz", s.frequency_hz, "in [0.001, 100] Hz");
    }
    if !(s.duration_s.is_finite() && s.duration_s > 0.0 && s.duration_s <= 86_400.0) {
        return bad("duration_s", s.duration_s, "in (0, 86400] s");
    }
    Ok(())
}

/// A number as an error shows it: as written, but for a million and more in exponent form (1e300
/// written out is 301 digits).
fn shown(x: f64) -> String {
    if x.abs() >= 1e6 { format!("{x:.3e}") } else { format!("{x}") }
}

/// The checks of `sim record`'s options beyond each segment's: the sample rate a config's loop
/// may run at ([1, 10000] Hz, `rate_hz`'s rule), every sine below half of it (at or above, the
/// record holds its alias, not the sine); `experiment` the file the segments come from, if not
/// the command line.
pub(crate) fn check_record_options(segments: &[Segment], rate_hz: f64, experiment: Option<&std::path::Path>) -> Result<(), String> {
    let cli = experiment.is_none();
    if !(1.0..=10_000.0).contains(&rate_hz) {
        return Err(format!("--rate: {} must be in [1, 10000] Hz (a config's loop rate)", shown(rate_hz)));
    }
    for (i, s) in segments.iter().enumerate() {
        if cli {
            check_segment(s, |f| format!("--{}", f.split('_').next().unwrap_or(f)))?;
        }
        if s.frequency_hz >= rate_hz / 2.0 {
            let which = experiment.map_or("--frequency".to_string(), |file| format!("{}: segments[{i}].frequency_hz", file.display()));
            return Err(format!("{which}: {} Hz is not below half the sample rate (--rate {rate_hz} Hz): the record would hold its alias, not the sine", s.frequency_hz));
        }
    }
    Ok(())
}

/// Whether chapter 5's tracking of `joint` can be measured as asked: each DOF run needs the F/T
/// sensor the tracking is measured against (a DOF without one printed NRMSE -0.000 and gain
/// 0.00), and each stiffness asked for must be a setting the joint has, within its configured
/// stiffness limits (0 or NaN ran at the default pivot, 5000 at the stiffest end, and the
/// request was nowhere in the output).
pub(crate) fn tracking_request_is_measurable(loaded: &jointctl_config::LoadedConfig, joint: &str, whole_entry: bool, stiffness: &[f64]) -> Result<(), String> {
    let entry = loaded.config.joints.iter().find(|j| (whole_entry && j.name == joint) || j.dof_names().contains(&joint));
    let Some(entry) = entry else { return Ok(()) };
    let names = entry.dof_names();
    let dofs: Vec<usize> = if whole_entry { (0..names.len()).collect() } else { names.iter().position(|n| *n == joint).into_iter().collect() };
    let sensors = entry.dof_torque_sensors();
    for &i in &dofs {
        if sensors[i].1.is_none() {
            return Err(format!("`{}` has no F/T sensor ({}.{} is not set): torque tracking is measured against it", names[i], entry.name, sensors[i].0));
        }
    }
    let limits = entry.dof_limits()[dofs[0]].and_then(|l| l.stiffness_nm_per_rad);
    for k in stiffness {
        match limits {
            _ if *k <= 0.0 => return Err(format!("--stiffness {k}: a stiffness must be positive [Nm/rad]")),
            Some([lo, hi]) if !(lo..=hi).contains(k) => {
                return Err(format!("--stiffness {k}: `{}` is configured for {lo}-{hi} Nm/rad (limits.stiffness_nm_per_rad): a setting outside is not one it can take", names[dofs[0]]));
            }
            _ => {}
        }
    }
    Ok(())
}

/// How far the pivot may settle from the setting `sim record` asked for [mm] (an assumption:
/// the simulated pivot drive settles within a few hundredths of a millimetre in its 3 s).
pub(crate) const PIVOT_TOLERANCE_MM: f64 = 0.5;
