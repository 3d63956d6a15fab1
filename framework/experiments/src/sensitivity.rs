//! What limited the thesis' arm (section 6.2 blames the 40 Hz loop and the bus latency, and
//! recommends gain scheduling and tuning the ELMO drives): the torque-tracking sweep of the
//! `thesis` scenario repeated with one factor changed at a time, towards the modern set-up or
//! away from it, each run's bandwidth and errors side by side.

use jointctl_config::LoadedConfig;
use jointctl_modes::Waveform;
use jointctl_runtime::PluginLoader;

use crate::tracking::{Plan, Row, Scenario, bandwidth_hz, run_as_configured};
use crate::{ExperimentError, locate};

/// "Poor" tracking: the F/T sensor's NRMSE against the reference above this (a fifth of the
/// amplitude). An assumption: the thesis says "good at 0.1-0.2 Hz, poor above" without a number.
pub const POOR_NRMSE: f64 = 0.2;

/// One factor at one value.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Variant {
    /// The factor changed (`loop rate`, `feedback latency`, ...).
    pub factor: String,
    /// Its value in this run.
    pub value: String,
    /// -3 dB and < 90 degrees lag bandwidth of the sensor torque [Hz] (see [`bandwidth_hz`]).
    pub bandwidth_hz: Option<f64>,
    /// The highest swept frequency up to which the sensor's NRMSE stays within [`POOR_NRMSE`] [Hz].
    pub good_up_to_hz: f64,
    /// Sensor NRMSE at 0.2 Hz (the thesis' limit) and at 2 Hz.
    pub nrmse_sensor_at_0_2_hz: f64,
    /// See `nrmse_sensor_at_0_2_hz`.
    pub nrmse_sensor_at_2_hz: f64,
    /// Observer vs F/T sensor NRMSE at 0.2 Hz: the observer's offset, which no loop setting removes.
    pub nrmse_observer_vs_sensor_at_0_2_hz: f64,
}

type Change = Box<dyn Fn(&mut LoadedConfig, usize, usize)>;

/// The factors and values tried, each a change of the thesis scenario's configuration (joint
/// entry `j`, DOF `i`). Values are assumptions spanning the thesis' set-up and a modern one.
fn changes() -> Vec<(&'static str, String, Change)> {
    let mut out: Vec<(&'static str, String, Change)> = vec![("none (thesis scenario)", "40 Hz, SPI 15 ms, CAN 30 ms".into(), Box::new(|_, _, _| {}))];
    for rate in [100.0, 250.0, 1000.0] {
        out.push(("loop rate", format!("{rate} Hz"), Box::new(move |c, _, _| c.config.rate_hz = rate)));
    }
    for s in [0.001, 0.030, 0.045, 0.060] {
        out.push(("feedback latency (SPI)", format!("{} ms", s * 1e3), Box::new(move |c, _, _| c.config.hal.sim.spi_latency_s = s)));
    }
    for s in [0.001, 0.060, 0.120] {
        out.push(("command latency (CAN)", format!("{} ms", s * 1e3), Box::new(move |c, _, _| c.config.hal.sim.can_latency_s = s)));
    }
    for f in [0.1, 0.25, 4.0] {
        out.push((
            "drive profile limits",
            format!("velocity and acceleration x{f}"),
            Box::new(move |c, _, _| {
                c.config.hal.sim.elmo.max_velocity_rad_s *= f;
                c.config.hal.sim.elmo.max_acceleration_rad_s2 *= f;
                // Faster drives need a plausibility bound that lets their readings through
                // (10 rad/s by default: at 12 rad/s the readings were rejected and the joint
                // held, which is a fault, not a bandwidth).
                if f > 1.0 {
                    for bus in &mut c.config.buses.can {
                        bus.drives.iter_mut().for_each(|d| d.max_velocity_rad_s *= f);
                    }
                    for bus in &mut c.config.buses.spi {
                        bus.encoders.iter_mut().for_each(|e| e.max_velocity_rad_s *= f);
                    }
                }
            }),
        ));
    }
    out.push(("PI gains", "no gain scheduling (section 6.2 off)".into(), Box::new(|c, j, i| with_controller(c, j, i, |ctl| ctl.torque_pi_schedule.clear()))));
    for f in [0.5, 1.5, 2.0] {
        out.push((
            "PI gains",
            format!("kp and ki x{f}"),
            Box::new(move |c, j, i| {
                with_controller(c, j, i, |ctl| {
                    ctl.torque_pi.kp *= f;
                    ctl.torque_pi.ki *= f;
                    for p in &mut ctl.torque_pi_schedule {
                        p.kp *= f;
                        p.ki *= f;
                    }
                })
            }),
        ));
    }
    for tau in [0.02, 0.1] {
        out.push((
            "observer filtering",
            format!("torque low-pass {} ms", tau * 1e3),
            Box::new(move |c, j, _| {
                // Only the shoulder's observer has a filter to set (`torque_filter_s`); the row
                // is left out for other joints (see `applies`).
                if let Some(params) = c.config.joints[j].params.0.as_object_mut() {
                    params.insert("torque_filter_s".into(), tau.into());
                }
            }),
        ));
    }
    out.push((
        "plant",
        "no hysteresis, friction, mode or noise".into(),
        Box::new(|c, j, _| {
            if let Some(sim) = c.config.joints[j].sim.as_mut() {
                // Every form the effects take: one set, one per DOF, one per pivot setting.
                sim.effects = Default::default();
                sim.effects_per_dof.clear();
                sim.effects_by_pivot.clear();
            }
        }),
    ));
    out.push(("all (modern scenario)", "1 kHz, SPI 1 ms, CAN 1 ms".into(), Box::new(|c, _, _| Scenario::Modern.apply(c))));
    out
}

/// Changes DOF `i`'s controller settings; a DOF without any gets the defaults first (so that a
/// change of gains is not silently a change of nothing).
fn with_controller(c: &mut LoadedConfig, j: usize, i: usize, f: impl Fn(&mut jointctl_config::ControllerConfig)) {
    let joint = &mut c.config.joints[j];
    let ctl = match joint.dofs.get_mut(i) {
        Some(d) => d.controller.get_or_insert_with(Default::default),
        None => joint.controller.get_or_insert_with(Default::default),
    };
    f(ctl);
}

/// Whether a factor can be changed on joint entry `j`: the observer's filter exists in the
/// shoulder's plugin only.
fn applies(loaded: &LoadedConfig, j: usize, factor: &str) -> bool {
    factor != "observer filtering" || loaded.config.joints[j].plugin.name == "vsa_shoulder"
}

/// The sweep each variant runs: sines from 0.1 to 4 Hz at one stiffness setting.
pub fn plan(stiffness_nm_per_rad: f64) -> Plan {
    Plan { stiffness_nm_per_rad: vec![stiffness_nm_per_rad], references: [0.1, 0.2, 0.5, 1.0, 2.0, 4.0].iter().map(|f| (Waveform::Sine, *f)).collect(), periods: 2.0, ..Plan::default() }
}

fn summary(factor: &str, value: String, rows: &[Row]) -> Variant {
    let at = |f: f64| rows.iter().find(|r| (r.frequency_hz - f).abs() < 1e-9);
    let good_up_to_hz = rows.iter().take_while(|r| r.nrmse_sensor <= POOR_NRMSE).map(|r| r.frequency_hz).fold(0.0, f64::max);
    Variant {
        factor: factor.into(),
        value,
        bandwidth_hz: bandwidth_hz(rows),
        good_up_to_hz,
        nrmse_sensor_at_0_2_hz: at(0.2).map_or(f64::NAN, |r| r.nrmse_sensor),
        nrmse_sensor_at_2_hz: at(2.0).map_or(f64::NAN, |r| r.nrmse_sensor),
        nrmse_observer_vs_sensor_at_0_2_hz: at(0.2).map_or(f64::NAN, |r| r.nrmse_observer_vs_sensor),
    }
}

/// Runs every variant on DOF `joint` at one stiffness; `progress(done, total)` after each.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let loaded = jointctl_config::load(std::path::Path::new("configs/sherpa_arm.yaml"))?;
/// let loader = jointctl_runtime::loader_for(&loaded);
/// let table = jointctl_experiments::sensitivity::run(&loaded, &loader, "q2", 89.0, |_, _| {})?;
/// assert_eq!(table[0].factor, "none (thesis scenario)");
/// # Ok(()) }
/// ```
pub fn run(loaded: &LoadedConfig, loader: &PluginLoader, joint: &str, stiffness_nm_per_rad: f64, mut progress: impl FnMut(usize, usize)) -> Result<Vec<Variant>, ExperimentError> {
    let (j, i) = locate(loaded, joint)?;
    let all: Vec<_> = changes().into_iter().filter(|(factor, ..)| applies(loaded, j, factor)).collect();
    let mut out = Vec::new();
    for (k, (factor, value, change)) in all.iter().enumerate() {
        let mut cfg = loaded.clone();
        Scenario::Thesis.apply(&mut cfg);
        change(&mut cfg, j, i);
        let rows = run_as_configured(&cfg, loader, joint, Scenario::Thesis, &plan(stiffness_nm_per_rad), |_, _| {})?;
        out.push(summary(factor, value.clone(), &rows));
        progress(k + 1, all.len());
    }
    Ok(out)
}

/// The table, Markdown.
pub fn table(variants: &[Variant]) -> String {
    let mut t = format!(
        "| factor changed | value | bandwidth [Hz] | good up to [Hz] (sensor NRMSE <= {POOR_NRMSE}) | sensor NRMSE at 0.2 Hz | at 2 Hz | observer vs sensor at 0.2 Hz |\n|---|---|---|---|---|---|---|\n"
    );
    for v in variants {
        t += &format!(
            "| {} | {} | {} | {} | {:.3} | {:.3} | {:.3} |\n",
            v.factor,
            v.value,
            v.bandwidth_hz.map_or("-".into(), |b| b.to_string()),
            v.good_up_to_hz,
            v.nrmse_sensor_at_0_2_hz,
            v.nrmse_sensor_at_2_hz,
            v.nrmse_observer_vs_sensor_at_0_2_hz
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Finding: a DOF without `controller:` settings (the wrist's) kept its default gains when
    /// a row scaled them, so the gain rows silently measured nothing. Pass: the scaled gains are
    /// twice the defaults.
    #[test]
    fn scaling_the_gains_of_a_dof_without_controller_settings_scales_the_defaults() {
        let yaml = "arm: a\nhal: {backend: sim}\njoints: [{name: w, plugin: p, dofs: [{name: q6}, {name: q7}]}]\n";
        let mut cfg = jointctl_config::parse_str(yaml, std::path::Path::new("a.yaml")).unwrap();
        let defaults = jointctl_config::ControllerConfig::default().torque_pi;
        let (_, _, double) = changes().into_iter().find(|(f, v, _)| *f == "PI gains" && v == "kp and ki x2").unwrap();
        double(&mut cfg, 0, 1);
        let got = cfg.config.joints[0].dofs[1].controller.as_ref().expect("the DOF got controller settings").torque_pi;
        assert_eq!((got.kp, got.ki), (2.0 * defaults.kp, 2.0 * defaults.ki));
        assert!(cfg.config.joints[0].dofs[0].controller.is_none(), "only the DOF asked for");
    }

    /// Finding: the row without plant effects cleared `sim.effects` alone, so a joint whose
    /// effects are given per DOF (the wrist) or per pivot setting kept them. Pass: none is left.
    #[test]
    fn the_row_without_plant_effects_clears_every_form_of_them() {
        let mut cfg = jointctl_config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sherpa_arm.yaml")).unwrap();
        let j = cfg.config.joints.iter().position(|j| j.name == "wrist").unwrap();
        let loop_set: jointctl_config::EffectsConfig = serde_json::from_value(serde_json::json!({"torque_offset_nm": 0.5})).unwrap();
        let sim = cfg.config.joints[j].sim.as_mut().unwrap();
        sim.effects_per_dof = vec![loop_set; 2];
        sim.effects_by_pivot = vec![jointctl_config::PivotEffectsConfig { pivot_mm: 10.0, effects: loop_set, effects_per_dof: Vec::new() }];
        let (_, _, clear) = changes().into_iter().find(|(f, _, _)| *f == "plant").unwrap();
        clear(&mut cfg, j, 0);
        let sim = cfg.config.joints[j].sim.as_ref().unwrap();
        assert!(sim.effects_per_dof.is_empty() && sim.effects_by_pivot.is_empty() && sim.effects.torque_offset_nm == 0.0);
    }
}
