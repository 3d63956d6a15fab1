//! `jointctl fit`: the thesis' fit step on a measured record.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use jointctl_experiments::plot::{COLORS, Series, lines};
use jointctl_ident::fit::{FitOptions, Order, fit};

use super::load_data;

#[derive(Args)]
pub struct FitArgs {
    /// Measured experiment: CSV (t, deflection, torque[, pivot_mm, angle_deg, ...]) or a
    /// recording (`jointctl record`, .mcap, with --joint).
    data: PathBuf,
    /// The joint to take from a recording (.mcap): its deflection and F/T torque.
    #[arg(long)]
    joint: Option<String>,
    /// Moving-average window [samples], 1 to 1000; default the thesis': 8 for a shoulder
    /// characterisation (by pivot), 5 for the wrist's (by pivot and direction), none otherwise.
    /// (1000 is an assumption: a second of a 1 kHz log, far beyond the thesis' windows; a window
    /// of 1e9 samples smoothed every setting to one value.)
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1000))]
    smooth: Option<u64>,
    /// Polynomial order 1-6, or `auto` (the lowest whose curve runs through the middle of the
    /// hysteresis band and the dead zone as well as higher orders, section 3.3.2).
    #[arg(long, default_value = "auto")]
    order: String,
    /// Separate fits for positive and negative deflection.
    #[arg(long)]
    branches: bool,
    /// Do not force zero torque at zero deflection (the curve gets an offset).
    #[arg(long)]
    no_through_zero: bool,
    /// Write the characteristic here, in the form the joint plugins load (use it with
    /// `params: {include: FILE}`); default: print it.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write plots (measured loop and fitted curve per setting) into this folder.
    #[arg(long)]
    report: Option<PathBuf>,
}

pub fn run_fit(a: FitArgs) -> ExitCode {
    let data = match load_data(&a.data, a.joint.as_deref()) {
        Ok(d) => d,
        Err(e) => return crate::fail(e),
    };
    for n in &data.notes {
        eprintln!("note: {n}");
    }
    let order = match a.order.as_str() {
        "auto" => Order::Auto(6),
        s => match s.parse::<usize>() {
            Ok(n) => Order::Fixed(n),
            Err(_) => return crate::fail(format!("--order must be 1-6 or `auto`, got `{s}`")),
        },
    };
    let smoothing_window = a.smooth.map_or_else(|| jointctl_ident::fit::thesis_smoothing(&data), |w| w as usize).max(1);
    let opts = FitOptions { smoothing_window, order, branches: a.branches, through_zero: !a.no_through_zero };
    let result = match fit(&data, &opts) {
        Ok(r) => r,
        Err(e) => return crate::fail(format!("{}: {e}", a.data.display())),
    };
    eprintln!("| pivot [mm] | angle [deg] | samples | order | stiffness [Nm/rad] | RMSE [Nm] | max error [Nm] | RMSE + / - [Nm] |");
    eprintln!("|---|---|---|---|---|---|---|---|");
    for g in &result.groups {
        eprintln!(
            "| {} | {} | {} | {} | {:.4} | {:.4} | {:.4} | {:.4} / {:.4} |",
            g.pivot_mm.map_or("-".into(), |p| p.to_string()),
            g.angle_deg.map_or("-".into(), |p| p.to_string()),
            g.samples,
            g.order,
            g.curve.stiffness_nm_per_rad,
            g.rmse_nm,
            g.max_error_nm,
            g.branch_rmse_nm.0,
            g.branch_rmse_nm.1
        );
    }
    let yaml = match serde_yaml::to_string(&serde_json::json!({ "version": jointctl_config::FORMAT_VERSION, "characteristic": result.spec })) {
        Ok(y) => format!("# Fitted by `jointctl fit {}` (smoothing {}, order {}, branches {}, through zero {}).\n{y}", a.data.display(), opts.smoothing_window, a.order, opts.branches, opts.through_zero),
        Err(e) => return crate::fail_err(e),
    };
    match &a.out {
        Some(path) => {
            let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
            if let Err(e) = parent.map_or(Ok(()), std::fs::create_dir_all).and_then(|_| std::fs::write(path, &yaml)) {
                return crate::fail(format!("cannot write {}: {e}", path.display()));
            }
            eprintln!("characteristic written to {}", path.display());
        }
        None => out!("{yaml}"),
    }
    if let Some(dir) = &a.report {
        if let Err(e) = std::fs::create_dir_all(dir) {
            return crate::fail(format!("cannot create {}: {e}", dir.display()));
        }
        for g in &result.groups {
            let single = jointctl_models::characteristic::CharacteristicSpec {
                source: result.spec.source,
                curves: vec![jointctl_models::characteristic::CurveSpec { pivot_mm: None, angle_deg: None, ..g.curve.clone() }],
            };
            let Ok(curve) = jointctl_models::characteristic::PivotCharacteristic::from_spec(&single) else { continue };
            let (lo, hi) = g.points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.0), h.max(p.0)));
            let fitted: Vec<(f64, f64)> = (0..=200).map(|i| lo + (hi - lo) * i as f64 / 200.0).map(|x| (x, curve.evaluate(0.0, x).torque_nm)).collect();
            // Files and titles name only the settings the data has.
            let (mut name, mut title) = (String::from("fit"), format!("torque-deflection, order {}", g.order));
            if let Some(p) = g.pivot_mm {
                name += &format!("-pivot{p}mm");
                title += &format!(", pivot {p} mm");
            }
            if let Some(a) = g.angle_deg {
                name += &format!("-angle{a}deg");
                title += &format!(", angle {a} deg");
            }
            name += ".svg";
            if let Err(e) = lines(&dir.join(name), &title, "deflection [rad]", "torque [Nm]", &[
                Series { name: "measured", points: g.points.clone(), color: COLORS[1] },
                Series { name: "fitted", points: fitted, color: COLORS[2] },
            ]) {
                return crate::fail_err(e);
            }
        }
        eprintln!("plots written to {}", dir.display());
    }
    ExitCode::SUCCESS
}
