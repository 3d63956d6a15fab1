//! A variable-stiffness joint characterised over its stiffness settings, as the thesis did for
//! the shoulder (section 3.4.2): at each pivot setting the output is deflected by a sine while
//! the torque sensor measures; the recordings, one after another in time, are the data
//! `jointctl fit` turns into the table the joint's observer loads. On the simulated arm this
//! makes the observer's table from the plant, the thesis' way, instead of copying it.

use jointctl_config::{ElementSimConfig, LoadedConfig};
use jointctl_models::lever_arm::LeverArm;
use jointctl_runtime::PluginLoader;

use crate::record::{RecordOptions, Sample, record};
use crate::{ExperimentError, locate};

/// The settings and motion of a characterisation.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Pivot settings [mm], in the order recorded; empty for a joint without one (an elastic
    /// joint: one recording).
    pub pivots_mm: Vec<f64>,
    /// Torque the deflection amplitude aims at [Nm]: `amplitude = torque / K(pivot) + play`.
    pub target_torque_nm: f64,
    /// Largest deflection amplitude [rad] (a soft setting cannot be deflected to its torque).
    pub max_deflection_rad: f64,
    /// Frequency of the sine [Hz].
    pub frequency_hz: f64,
    /// Sine cycles per setting.
    pub cycles: f64,
    /// Sample rate [Hz].
    pub rate_hz: f64,
    /// Deflection directions [deg] of a 2-DOF joint (0 = its second DOF only, 90 = its first);
    /// empty for a 1-DOF joint.
    pub angles_deg: Vec<f64>,
}

impl Plan {
    /// Section 3.4.2's shoulder characterisation: ten settings, 0 to 45 mm in 5 mm steps. The
    /// thesis gives neither the amplitudes nor the frequency; assumed: the torque of the largest
    /// characterised step (about 25 Nm, [`jointctl_models::assumed::SHOULDER_MAX_TORQUE_NM`];
    /// figure 5.2 steps to 20 Nm), at most 0.35 rad (the assumed tables' range), two cycles of
    /// 0.2 Hz (slow against every mode, so the loop shows hysteresis, not dynamics), sampled at
    /// 100 Hz.
    ///
    /// ```
    /// let plan = jointctl_experiments::characterise::Plan::shoulder();
    /// assert_eq!(plan.pivots_mm.len(), 10);
    /// assert_eq!(plan.pivots_mm[9], 45.0);
    /// ```
    pub fn shoulder() -> Plan {
        Plan {
            pivots_mm: (0..10).map(|k| 5.0 * k as f64).collect(),
            target_torque_nm: jointctl_models::assumed::SHOULDER_MAX_TORQUE_NM,
            max_deflection_rad: 0.35,
            frequency_hz: 0.2,
            cycles: 2.0,
            rate_hz: 100.0,
            angles_deg: Vec::new(),
        }
    }

    /// Section 3.3.2's characterisation of an elastic joint (the elbow q4): one setting, the
    /// output deflected back and forth. Assumed as for the shoulder: 20 Nm (figure 3.9 prints
    /// no range; two thirds of the elbow's assumed 30 Nm limit), at most 0.35 rad, two cycles of
    /// 0.2 Hz at 100 Hz.
    ///
    /// ```
    /// let plan = jointctl_experiments::characterise::Plan::elastic();
    /// assert!(plan.pivots_mm.is_empty() && plan.angles_deg.is_empty());
    /// ```
    pub fn elastic() -> Plan {
        Plan { pivots_mm: Vec::new(), target_torque_nm: 20.0, ..Plan::shoulder() }
    }

    /// Section 3.5.2's wrist characterisation: eleven settings, 0 to 50 mm in 5 mm steps, each
    /// along four directions (0, 45, 90, 135 deg). Assumed as for the shoulder: the torque aimed
    /// at is the wrist's largest characterised one (3 Nm, [`jointctl_models::assumed::WRIST_MAX_TORQUE_NM`];
    /// figure 5.16 steps to 2 Nm), at most 0.35 rad, two cycles of 0.2 Hz at 100 Hz.
    ///
    /// ```
    /// let plan = jointctl_experiments::characterise::Plan::wrist();
    /// assert_eq!((plan.pivots_mm.len(), plan.angles_deg.len()), (11, 4));
    /// ```
    pub fn wrist() -> Plan {
        Plan {
            pivots_mm: (0..11).map(|k| 5.0 * k as f64).collect(),
            target_torque_nm: jointctl_models::assumed::WRIST_MAX_TORQUE_NM,
            angles_deg: vec![0.0, 45.0, 90.0, 135.0],
            ..Plan::shoulder()
        }
    }
}

/// The simulated element's stiffness near zero deflection at a pivot setting (and direction,
/// for the wrist) [Nm/rad] and its play [rad]: what the person characterising the joint knows
/// beforehand to choose deflections (from the joint's design, eq. 2.6), not the table being made.
fn plant_stiffness(loaded: &LoadedConfig, joint: &str, pivot_mm: f64, angle_deg: f64) -> Result<(f64, f64), ExperimentError> {
    let (j, i) = locate(loaded, joint)?;
    let sim = loaded.config.joints[j].sim.as_ref().ok_or_else(|| ExperimentError(format!("`{joint}` has no simulated hardware")))?;
    let element = sim.elements.get(i).or(sim.element.as_ref());
    match element {
        Some(ElementSimConfig::LeverArm { lever_length_m, crank_radius_m, spring_n_per_m, pivot_offset_m, dead_zone_rad, .. }) => {
            let lever = LeverArm { lever_length_m: *lever_length_m, crank_radius_m: *crank_radius_m, spring_n_per_m: *spring_n_per_m, pivot_offset_m: *pivot_offset_m };
            Ok((lever.stiffness_at(pivot_mm), *dead_zone_rad))
        }
        Some(ElementSimConfig::WristLeverArm { lever_length_m, crank_radius_m, spring_n_per_m, pivot_offset_m, dead_zone_rad, anisotropy, .. }) => {
            let lever = LeverArm { lever_length_m: *lever_length_m, crank_radius_m: *crank_radius_m, spring_n_per_m: *spring_n_per_m, pivot_offset_m: *pivot_offset_m };
            Ok((lever.stiffness_at(pivot_mm) * (1.0 + anisotropy * (2.0 * angle_deg.to_radians()).cos()), *dead_zone_rad))
        }
        Some(ElementSimConfig::Linear { stiffness_nm_per_rad }) => Ok((*stiffness_nm_per_rad, sim.effects.dead_zone_rad)),
        // Said with the element the joint has: a rigid joint was told about a `pivot_table`.
        other => {
            let has = match other {
                Some(ElementSimConfig::Rigid) => "it is rigid: nothing deflects",
                None => "it has no simulated element",
                Some(ElementSimConfig::PivotTable | ElementSimConfig::WristTable) => "its table element is the observer's own table, not a plant to characterise",
                Some(_) => "its element has no stiffness to choose deflections by",
            };
            Err(ExperimentError(format!("`{joint}`: a characterisation needs a simulated `lever_arm`, `wrist_lever_arm` or `linear` element, whose stiffness chooses the deflections; {has}")))
        }
    }
}

/// Records `plan` on DOF `joint`: every setting in turn, one time axis (each recording starts
/// one sample period after the previous one ends).
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let loaded = jointctl_config::load(std::path::Path::new("configs/sherpa_arm.yaml"))?;
/// let loader = jointctl_runtime::loader_for(&loaded);
/// let samples = jointctl_experiments::characterise::characterise(&loaded, &loader, "q2", &jointctl_experiments::characterise::Plan::shoulder())?;
/// assert!(samples.len() > 9000);
/// # Ok(()) }
/// ```
pub fn characterise(loaded: &LoadedConfig, loader: &PluginLoader, joint: &str, plan: &Plan) -> Result<Vec<Sample>, ExperimentError> {
    let mut out: Vec<Sample> = Vec::new();
    let angles = if plan.angles_deg.is_empty() { vec![0.0] } else { plan.angles_deg.clone() };
    let settings: Vec<Option<f64>> = if plan.pivots_mm.is_empty() { vec![None] } else { plan.pivots_mm.iter().map(|&p| Some(p)).collect() };
    for &pivot_mm in &settings {
        for &angle_deg in &angles {
            let (k, play) = plant_stiffness(loaded, joint, pivot_mm.unwrap_or(0.0), angle_deg)?;
            let amplitude_rad = (plan.target_torque_nm / k + play).min(plan.max_deflection_rad);
            let opts = RecordOptions {
                joint: joint.to_string(),
                amplitude_rad,
                frequency_hz: plan.frequency_hz,
                duration_s: plan.cycles / plan.frequency_hz,
                pivot_mm,
                angle_deg,
                rate_hz: plan.rate_hz,
            };
            let start = out.last().map_or(0.0, |s| s.t + 1.0 / plan.rate_hz);
            out.extend(record(loaded, loader, &opts)?.into_iter().map(|s| Sample { t: s.t + start, ..s }));
        }
    }
    Ok(out)
}
