//! `jointctl calibrate`: each elastic joint's deflection zero, measured with the arm at rest in
//! the calibration pose (issue 37, finding 5: the plugins took the readings at activation as zero
//! deflection, so an arm that started under load read 0 Nm while it carried it).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use crate::{fail, fail_err, print_out};

#[derive(Args)]
pub struct CalibrateArgs {
    /// The arm description (its backend: the real buses with `socketcan`).
    config: PathBuf,
    /// Cycles averaged at rest.
    #[arg(long, default_value_t = 200)]
    cycles: u32,
    /// Write the zeros here (YAML) instead of to stdout.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// The pose: every elastic element unloaded (the arm's links supported, or each joint's output
/// free of torque), the drives holding. Each `elastic` joint's zero is the mean of its motor
/// side (its `input` encoder, or its `motor` drive) and of its `output` encoder over the cycles;
/// the shoulder's, the mean of its q2 deflection encoder; the wrist's, the means of its two
/// planet-carrier and two bevel-input encoders.
pub fn calibrate(a: &CalibrateArgs) -> ExitCode {
    let mut loaded = match jointctl_config::load(&a.config) {
        Ok(l) => l,
        Err(e) => return fail_err(e),
    };
    // Measured against the raw readings: a zero already in the config (maybe the wrong one that
    // made activation refuse) is not used.
    for j in &mut loaded.config.joints {
        if let Some(params) = j.params.0.as_object_mut() {
            params.remove("zero");
        }
    }
    let _locks = match crate::run::lock_hardware(&loaded) {
        Ok(l) => l,
        Err(e) => return fail_err(e),
    };
    let loader = match crate::experiment_loader(&loaded) {
        Ok(l) => l,
        Err(e) => return fail_err(e),
    };
    let mut arm = match jointctl_backends::build_arm(&loaded, &loader) {
        Ok(arm) => arm,
        Err(e) => return fail_err(e),
    };
    if let Err(e) = arm.activate() {
        return fail_err(e);
    }
    let devices = jointctl_hal::DeviceIndex::of(&loaded.config);
    // Per elastic joint: (name, motor side as (is an encoder, index), output encoder index).
    let mut joints = Vec::new();
    for j in loaded.config.joints.iter().filter(|j| j.plugin.name == "elastic") {
        let output = j.encoders.get("output").and_then(|n| devices.encoder(n));
        let input = match j.encoders.get("input") {
            Some(n) => devices.encoder(n).map(|i| (true, i)),
            None => j.drives.get("motor").and_then(|n| devices.drive(n)).map(|i| (false, i)),
        };
        if let (Some(output), Some(input)) = (output, input) {
            joints.push((j.name.clone(), input, output));
        }
    }
    // The shoulder's q2 deflection encoder (section 3.4.1 measures the deflection directly).
    let shoulders: Vec<(String, usize)> = loaded
        .config
        .joints
        .iter()
        .filter(|j| j.plugin.name == "vsa_shoulder")
        .filter_map(|j| Some((j.name.clone(), devices.encoder(j.encoders.get("q2_deflection")?)?)))
        .collect();
    // The wrist's carrier and bevel-input encoders (section 3.5.1), a then b.
    let wrists: Vec<(String, [usize; 4])> = loaded
        .config
        .joints
        .iter()
        .filter(|j| j.plugin.name == "vsa_wrist")
        .filter_map(|j| {
            let at = |role: &str| devices.encoder(j.encoders.get(role)?);
            Some((j.name.clone(), [at("carrier_a")?, at("carrier_b")?, at("bevel_a")?, at("bevel_b")?]))
        })
        .collect();
    if joints.is_empty() && shoulders.is_empty() && wrists.is_empty() {
        return fail(format!("{}: no elastic joint (output encoder and motor side), shoulder (q2 deflection encoder) or wrist (carrier and bevel encoders) to calibrate", a.config.display()));
    }
    let mut sums = vec![(0.0, 0.0, 0u32); joints.len()];
    let mut shoulder_sums = vec![(0.0, 0u32); shoulders.len()];
    let mut wrist_sums = vec![([0.0; 4], 0u32); wrists.len()];
    let period = std::time::Duration::from_secs_f64(arm.dt_s);
    for cycle in 0..a.cycles {
        arm.step(f64::from(cycle) * arm.dt_s);
        let r = arm.last_readings();
        for ((_, (is_encoder, i), o), sum) in joints.iter().zip(&mut sums) {
            let fresh = 2.0 * arm.dt_s;
            let input = if *is_encoder { r.encoders[*i].usable(fresh) } else { r.drives[*i].position_rad.usable(fresh) };
            if let (Some(input), Some(output)) = (input, r.encoders[*o].usable(fresh)) {
                *sum = (sum.0 + input, sum.1 + output, sum.2 + 1);
            }
        }
        for ((_, e), sum) in shoulders.iter().zip(&mut shoulder_sums) {
            if let Some(d) = r.encoders[*e].usable(2.0 * arm.dt_s) {
                *sum = (sum.0 + d, sum.1 + 1);
            }
        }
        for ((_, encoders), sum) in wrists.iter().zip(&mut wrist_sums) {
            let read: Option<Vec<f64>> = encoders.iter().map(|e| r.encoders[*e].usable(2.0 * arm.dt_s)).collect();
            if let Some(read) = read {
                read.iter().zip(sum.0.iter_mut()).for_each(|(x, s)| *s += x);
                sum.1 += 1;
            }
        }
        if loaded.config.hal.backend == jointctl_config::HalBackend::Socketcan {
            std::thread::sleep(period);
        }
    }
    arm.shutdown();
    let mut text = format!(
        "# Written by `jointctl calibrate {}` ({} cycles at rest, every elastic element unloaded).\n# Put each joint's `zero` under its params.\nversion: {}\njoints:\n",
        a.config.display(),
        a.cycles,
        jointctl_config::FORMAT_VERSION
    );
    for ((name, _, _), (input, output, n)) in joints.iter().zip(&sums) {
        if *n == 0 {
            return fail(format!("joint `{name}`: no fresh reading of its motor side and output encoder in {} cycles", a.cycles));
        }
        let _ = writeln!(text, "  {name}:\n    zero: {{input_rad: {:.9}, output_rad: {:.9}}}", input / f64::from(*n), output / f64::from(*n));
    }
    for ((name, _), (d, n)) in shoulders.iter().zip(&shoulder_sums) {
        if *n == 0 {
            return fail(format!("joint `{name}`: no fresh reading of its q2 deflection encoder in {} cycles", a.cycles));
        }
        let _ = writeln!(text, "  {name}:\n    zero: {{deflection_rad: {:.9}}}", d / f64::from(*n));
    }
    for ((name, _), (sum, n)) in wrists.iter().zip(&wrist_sums) {
        if *n == 0 {
            return fail(format!("joint `{name}`: no fresh reading of all four carrier and bevel encoders in {} cycles", a.cycles));
        }
        let m = sum.map(|x| x / f64::from(*n));
        let _ = writeln!(text, "  {name}:\n    zero: {{carrier_rad: [{:.9}, {:.9}], bevel_rad: [{:.9}, {:.9}]}}", m[0], m[1], m[2], m[3]);
    }
    match &a.out {
        Some(path) => {
            if let Err(e) = std::fs::write(path, &text) {
                return fail(format!("cannot write {}: {e}", path.display()));
            }
            eprintln!("zeros of {} joint(s) written to {}", joints.len() + shoulders.len() + wrists.len(), path.display());
        }
        None => print_out(&text),
    }
    ExitCode::SUCCESS
}
