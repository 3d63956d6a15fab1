//! `jointctl gravity`: the holding torques of a pose, from the arm's URDF (appendix C).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use jointctl_kinematics::{Gravity, appendix_c};

use crate::{fail, fail_err, print_out};

#[derive(Args)]
pub struct GravityArgs {
    /// The arm description (its `kinematics.urdf`).
    config: PathBuf,
    /// Joint positions [rad], `q2=0.785,q4=-0.3`; joints not named are at 0.
    #[arg(long, conflicts_with = "pose")]
    q: Option<String>,
    /// A named pose: `appendix-c` is figure C.1 (q2 at 45 degrees, every body 1 kg), printed
    /// next to figure C.2's solver values and eq. C.3's hand values.
    #[arg(long, value_enum)]
    pose: Option<NamedPose>,
    /// Print `{"pose": {"q1": rad, ...}, "torques_nm": {"q1": Nm, ...}}`.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum NamedPose {
    /// Figure C.1: the stretched arm at 45 degrees, every body 1 kg.
    AppendixC,
}

/// The largest angle `--q` takes [rad]: one turn either way. Gravity repeats each turn, so a
/// larger angle adds nothing; it is most likely degrees typed as radians (an angle of 1e300 was
/// taken and printed with its 300 digits, though at that size an f64 no longer resolves a turn).
const MAX_ANGLE_RAD: f64 = std::f64::consts::TAU;

/// `q2=0.785,q4=-0.3` onto the chain's DOFs (the rest 0).
fn parse_pose(text: &str, dofs: &[String]) -> Result<Vec<f64>, String> {
    let mut q = vec![0.0; dofs.len()];
    let mut given = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, value) = item.split_once('=').ok_or_else(|| format!("--q: `{item}` is not JOINT=RADIANS"))?;
        let (name, value) = (name.trim(), value.trim());
        let k = dofs.iter().position(|d| d == name).ok_or_else(|| format!("--q: `{name}` is not a joint of the URDF ({})", dofs.join(", ")))?;
        let v: f64 = value.parse().map_err(|_| format!("--q: {name}: `{value}` is not a number [rad]"))?;
        if !v.is_finite() {
            return Err(format!("--q: {name}: {v} is not a finite angle"));
        }
        if v.abs() > MAX_ANGLE_RAD {
            return Err(format!("--q: {name}: {value} rad is more than a turn either way (at most {MAX_ANGLE_RAD:.4}): gravity repeats each turn, and a larger number is most likely degrees; --q takes radians"));
        }
        if given.contains(&k) {
            return Err(format!("--q: `{name}` is given twice"));
        }
        given.push(k);
        q[k] = v;
    }
    Ok(q)
}

pub fn run(a: GravityArgs) -> ExitCode {
    let loaded = match jointctl_config::load(&a.config) {
        Ok(l) => l,
        Err(e) => return fail_err(e),
    };
    let (Some(chain), Some(k)) = (loaded.chain.clone(), loaded.config.kinematics.as_ref()) else {
        return fail(format!("{}: no `kinematics: {{urdf: FILE}}`: the arm's links and masses are unknown", a.config.display()));
    };
    let chain = match a.pose {
        Some(NamedPose::AppendixC) => appendix_c::masses(&chain),
        None => chain,
    };
    let dofs = chain.dof_names().to_vec();
    let q = match (&a.q, a.pose) {
        (Some(text), _) => match parse_pose(text, &dofs) {
            Ok(q) => q,
            Err(e) => return fail(e),
        },
        (None, Some(NamedPose::AppendixC)) => match appendix_c::pose(&dofs) {
            Some(q) => q,
            None => return fail("--pose appendix-c: the URDF has no joint `q2` (the shoulder, figure C.1)"),
        },
        (None, None) => vec![0.0; dofs.len()],
    };
    let mut gravity = Gravity::downward(chain, k.gravity_m_s2);
    let mut tau = vec![0.0; dofs.len()];
    if let Err(e) = gravity.torques(&q, &mut tau) {
        return fail_err(e);
    }
    let appendix = matches!(a.pose, Some(NamedPose::AppendixC));
    if a.json {
        let map = |v: &[f64]| serde_json::Value::Object(dofs.iter().zip(v).map(|(d, x)| (d.clone(), (*x).into())).collect());
        let mut out = serde_json::json!({"pose": map(&q), "torques_nm": map(&tau), "gravity_m_s2": k.gravity_m_s2});
        if appendix {
            let refs = |r: &[(&str, f64)]| serde_json::Value::Object(r.iter().map(|(d, x)| (d.to_string(), (*x).into())).collect());
            out["figure_c2_nm"] = refs(&appendix_c::FIGURE_C2_NM);
            out["eq_c3_nm"] = refs(&appendix_c::EQ_C3_NM);
        }
        print_out(&format!("{out}\n"));
        return ExitCode::SUCCESS;
    }
    let mut text = format!(
        "Holding torques of `{}` ({} kg, g = {} m/s^2){}: the torque each joint applies so that gravity does not move the arm.\n\n",
        gravity.chain().name,
        gravity.chain().mass_kg(),
        k.gravity_m_s2,
        if appendix { ", figure C.1's pose and masses" } else { "" }
    );
    if appendix {
        text.push_str("| joint | q [deg] | torque [Nm] | figure C.2 [Nm] | difference | eq. C.3 [Nm] |\n|---|---|---|---|---|---|\n");
    } else {
        text.push_str("| joint | q [rad] | q [deg] | torque [Nm] |\n|---|---|---|---|\n");
    }
    for (i, d) in dofs.iter().enumerate() {
        if appendix {
            let fig = appendix_c::FIGURE_C2_NM.iter().find(|(n, _)| n == d).map(|x| x.1);
            let hand = appendix_c::EQ_C3_NM.iter().find(|(n, _)| n == d).map(|x| x.1);
            let _ = writeln!(
                text,
                "| {d} | {:.1} | {:.6} | {} | {} | {} |",
                q[i].to_degrees(),
                tau[i],
                fig.map_or("0 (not printed)".into(), |f| format!("{f}")),
                fig.map_or("".into(), |f| format!("{:+.3} %", 100.0 * (tau[i] - f) / f.abs())),
                hand.map_or("".into(), |h| format!("{h}"))
            );
        } else {
            let _ = writeln!(text, "| {d} | {:.6} | {:.2} | {:.6} |", q[i], q[i].to_degrees(), tau[i]);
        }
    }
    print_out(&text);
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_names_joints_of_the_urdf_and_finite_angles() {
        let dofs: Vec<String> = ["q1", "q2"].iter().map(|s| s.to_string()).collect();
        assert_eq!(parse_pose("q2=0.5", &dofs), Ok(vec![0.0, 0.5]));
        assert!(parse_pose("q9=0.5", &dofs).unwrap_err().contains("`q9` is not a joint of the URDF (q1, q2)"));
        assert!(parse_pose("q2=nan", &dofs).unwrap_err().contains("not a finite angle"));
        assert!(parse_pose("q2=1e300", &dofs).unwrap_err().contains("1e300 rad is more than a turn either way"));
        assert!(parse_pose("q2=45", &dofs).unwrap_err().contains("most likely degrees"));
        assert_eq!(parse_pose("q1=-6.2,q2=6.2", &dofs), Ok(vec![-6.2, 6.2]));
        assert!(parse_pose("q2=abc", &dofs).unwrap_err().contains("`abc` is not a number"));
        assert!(parse_pose("q2", &dofs).unwrap_err().contains("not JOINT=RADIANS"));
        assert!(parse_pose("q2=1,q2=2", &dofs).unwrap_err().contains("given twice"));
    }
}
