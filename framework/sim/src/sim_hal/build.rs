//! Building a [`SimHal`] from a configuration: its drives, units, encoders' models and
//! force/torque sensors, each checked and its error naming the field it came from.

use jointctl_config::{ArmConfig, EncoderSimConfig, LoadedConfig};
use jointctl_hal::condition::{Conditioner, Plausibility};
use jointctl_hal::{DeviceIndex, HalSetupError};
use jointctl_kinematics::Chain;

use super::{EncoderModel, SimHal, Term};
use crate::elmo::ElmoDrive;
use crate::free_arm::FreeArm;
use crate::latency::{DelayLine, InFlight};
use crate::rng::SplitMix64;
use crate::unit::{self, Element, SignalKind, Unit};

fn setup(field: impl Into<String>, message: impl Into<String>) -> HalSetupError {
    HalSetupError::Config { field: field.into(), message: message.into() }
}

impl SimHal {
    /// The simulated arm of a loaded configuration (with its URDF, for a free arm).
    pub fn load(loaded: &LoadedConfig) -> Result<Self, HalSetupError> {
        SimHal::with_chain(&loaded.config, loaded.chain.as_ref())
    }

    /// The simulated arm of a configuration without its URDF (no `free_arm` environment).
    pub fn new(config: &ArmConfig) -> Result<Self, HalSetupError> {
        SimHal::with_chain(config, None)
    }

    /// The simulated arm of a configuration and its kinematic chain (`kinematics.urdf`), which
    /// a `free_arm` environment needs.
    pub fn with_chain(config: &ArmConfig, chain: Option<&Chain>) -> Result<Self, HalSetupError> {
        let devices = DeviceIndex::of(config);
        let sim = &config.hal.sim;
        let drive_cfgs: Vec<_> = config.buses.can.iter().flat_map(|b| b.drives.iter()).collect();
        let drive_index = |name: &str, field: String| devices.drive(name).ok_or_else(|| setup(field, format!("no drive named `{name}`")));
        let mut elmo = vec![sim.elmo; drive_cfgs.len()];
        for (name, g) in &sim.drive_gains {
            let at = format!("hal.sim.drive_gains.{name}");
            let d = drive_index(name, at.clone())?;
            if !(g.kp > 0.0 && g.ki >= 0.0 && g.kd >= 0.0) {
                return Err(setup(at, format!("kp must be > 0, ki and kd >= 0 (got {}, {}, {})", g.kp, g.ki, g.kd)));
            }
            (elmo[d].kp, elmo[d].ki, elmo[d].kd) = (g.kp, g.ki, g.kd);
        }
        // Each drive keeps its target inside its software position limits, as told at start-up.
        let drives: Vec<ElmoDrive> = elmo
            .iter()
            .zip(&drive_cfgs)
            .map(|(e, c)| ElmoDrive::new(*e, 0.0).with_position_limits(c.setpoint_window_rad))
            .collect();

        let mut units = Vec::new();
        let mut unit_joint = Vec::new();
        for (j, joint) in config.joints.iter().enumerate() {
            let Some(s) = &joint.sim else { continue };
            unit_joint.push(j);
            let at = |f: &str| format!("joints[{j}].sim.{f}");
            let dof_names: Vec<String> = joint.dof_names().iter().map(|n| n.to_string()).collect();
            let drive_ids = s
                .drives
                .iter()
                .enumerate()
                .map(|(i, d)| drive_index(d, at(&format!("drives[{i}]"))))
                .collect::<Result<Vec<_>, _>>()?;
            if s.matrix.len() != dof_names.len() || s.matrix.iter().any(|r| r.len() != drive_ids.len() || r.iter().any(|m| !m.is_finite())) {
                return Err(setup(
                    at("matrix"),
                    format!("needs {} row(s) (one per DOF) of {} finite number(s) (one per drive)", dof_names.len(), drive_ids.len()),
                ));
            }
            let n = dof_names.len();
            let element_cfgs: Vec<_> = match (&s.element, s.elements.as_slice()) {
                (Some(e), []) => vec![e.clone()],
                (None, list) if list.len() == n => list.to_vec(),
                _ => return Err(setup(at("element"), format!("give `element` (all DOFs) or `elements` with {n} entries (one per DOF)"))),
            };
            let elements = element_cfgs
                .iter()
                .map(|e| Element::from_config(e, &joint.params.0, if element_cfgs.len() == 1 { n } else { 1 }))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|(f, m)| setup(format!("joints[{j}].{f}"), m))?;
            let environments: Vec<_> = match (&s.environment, s.environments.as_slice()) {
                (Some(e), []) => vec![e.clone(); n],
                (None, list) if list.len() == n => list.to_vec(),
                _ => return Err(setup(at("environment"), format!("give `environment` (all DOFs) or `environments` with {n} entries"))),
            };
            let pivot = match &s.pivot {
                Some(p) => Some((drive_index(&p.drive, at("pivot.drive"))?, p.mm_per_rad, p.offset_mm)),
                None => None,
            };
            unit::check_effects(&s.effects).map_err(|(f, m)| setup(at(&format!("effects.{f}")), m))?;
            if !s.effects_per_dof.is_empty() {
                if s.effects_per_dof.len() != n {
                    return Err(setup(at("effects_per_dof"), format!("give one set per DOF ({n}), got {}", s.effects_per_dof.len())));
                }
                if s.effects != jointctl_config::EffectsConfig::default() {
                    return Err(setup(at("effects"), "give `effects` (every DOF) or `effects_per_dof`, not both".to_string()));
                }
                for (i, fx) in s.effects_per_dof.iter().enumerate() {
                    unit::check_effects(fx).map_err(|(f, m)| setup(at(&format!("effects_per_dof[{i}].{f}")), m))?;
                }
            }
            if !s.effects_by_pivot.is_empty() {
                if pivot.is_none() {
                    return Err(setup(at("effects_by_pivot"), "the joint has no `pivot`: give `effects`".to_string()));
                }
                if s.effects != jointctl_config::EffectsConfig::default() || !s.effects_per_dof.is_empty() {
                    return Err(setup(at("effects_by_pivot"), "give one of `effects` (every DOF), `effects_per_dof` or `effects_by_pivot`".to_string()));
                }
            }
            let mut unit = Unit::new(dof_names, drive_ids, s.matrix.clone(), elements, pivot, environments, s.effects);
            for (i, fx) in s.effects_per_dof.iter().enumerate() {
                unit.set_effects(i, *fx);
            }
            if !s.effects_by_pivot.is_empty() {
                unit.set_effects_by_pivot(s.effects_by_pivot.clone()).map_err(|(f, m)| setup(at(&format!("effects_by_pivot{f}")), m))?;
            }
            units.push(unit);
        }
        let signal = |name: &str, field: String| -> Result<Term, HalSetupError> {
            let (dof, kind) = name.rsplit_once('.').ok_or_else(|| setup(field.clone(), format!("`{name}` is not DOF.SIGNAL")))?;
            let kind = SignalKind::parse(kind).ok_or_else(|| {
                setup(field.clone(), format!("unknown signal `{kind}`: use output, theta, deflection, torque or pivot_mm"))
            })?;
            units
                .iter()
                .enumerate()
                .find_map(|(u, unit)| unit.dof_names.iter().position(|n| n == dof).map(|d| Term::Signal { unit: u, dof: d, kind }))
                .ok_or_else(|| setup(field, format!("no simulated joint has a DOF `{dof}` (give that joint a `sim:` section)")))
        };

        let mut encoders = Vec::new();
        let mut quantized = Vec::new();
        let mut offsets = Vec::new();
        let mut rates = Vec::new();
        for (b, bus) in config.buses.spi.iter().enumerate() {
            for (i, e) in bus.encoders.iter().enumerate() {
                let field = format!("buses.spi[{b}].encoders[{i}].sim");
                let model = match &e.sim {
                    Some(EncoderSimConfig { fixed_rad: Some(q), .. }) => EncoderModel::Fixed(*q),
                    Some(EncoderSimConfig { drive: Some(d), gain, offset_rad, .. }) => {
                        EncoderModel::Sum { terms: vec![(Term::Drive(drive_index(d, format!("{field}.drive"))?), *gain)], offset_rad: *offset_rad }
                    }
                    Some(EncoderSimConfig { signal: Some(sig), gain, offset_rad, .. }) => {
                        EncoderModel::Sum { terms: vec![(signal(sig, format!("{field}.signal"))?, *gain)], offset_rad: *offset_rad }
                    }
                    Some(EncoderSimConfig { sum, offset_rad, .. }) if !sum.is_empty() => {
                        let mut terms = Vec::new();
                        for (t, term) in sum.iter().enumerate() {
                            let what = match (&term.drive, &term.signal) {
                                (Some(d), _) => Term::Drive(drive_index(d, format!("{field}.sum[{t}].drive"))?),
                                (None, Some(s)) => signal(s, format!("{field}.sum[{t}].signal"))?,
                                (None, None) => return Err(setup(format!("{field}.sum[{t}]"), "give `drive` or `signal`")),
                            };
                            terms.push((what, term.gain));
                        }
                        EncoderModel::Sum { terms, offset_rad: *offset_rad }
                    }
                    _ => {
                        return Err(setup(
                            field,
                            format!(
                                "the simulated backend needs to know what encoder `{}` reads: add `sim: {{drive: NAME}}`, `{{signal: DOF.output}}`, `{{sum: [...]}}` or `{{fixed_rad: Q}}`",
                                e.name
                            ),
                        ));
                    }
                };
                quantized.push(sim.quantize_encoders && e.sim.as_ref().is_none_or(|s| s.quantized));
                encoders.push(model);
                offsets.push(e.offset_rad);
                rates.push(e.max_velocity_rad_s);
            }
        }
        let mut torque_sensors = Vec::new();
        for (i, f) in config.buses.force_torque.iter().enumerate() {
            let field = format!("buses.force_torque[{i}].sim");
            let Some(sim_cfg) = &f.sim else {
                return Err(setup(field, format!("the simulated backend needs to know what sensor `{}` measures: add `sim: {{dof: NAME}}`", f.name)));
            };
            let at = units
                .iter()
                .enumerate()
                .find_map(|(u, unit)| unit.dof_names.iter().position(|n| *n == sim_cfg.dof).map(|d| (u, d)))
                .ok_or_else(|| setup(format!("{field}.dof"), format!("no simulated joint has a DOF `{}` (give that joint a `sim:` section)", sim_cfg.dof)))?;
            torque_sensors.push((at, f.range_nm, Conditioner::new(Plausibility::torque_sensor())));
        }
        let g_m_s2 = config.kinematics.as_ref().map_or(jointctl_kinematics::STANDARD_GRAVITY_M_S2, |k| k.gravity_m_s2);
        let free_arm = FreeArm::new(chain, g_m_s2, &units, |u| format!("joints[{}].sim.environment", unit_joint[u])).map_err(|(f, m)| setup(f, m))?;
        let n_drives = drives.len();
        let sensor_history = vec![DelayLine::new(); units.len() * unit::MAX_UNIT_DOF];
        let mut hal = SimHal {
            drives,
            units,
            sensor_history,
            encoder_history: vec![DelayLine::new(); encoders.len()],
            drive_history: vec![DelayLine::new(); n_drives],
            drive_torque_history: vec![DelayLine::new(); n_drives],
            drive_torque_last: vec![None; n_drives],
            encoder_conditioners: rates.iter().map(|r| Conditioner::new(Plausibility::absolute_encoder(*r))).collect(),
            drive_conditioners: drive_cfgs.iter().map(|d| Conditioner::new(Plausibility::drive_position(d.max_velocity_rad_s))).collect(),
            torque_sensors,
            counts_per_rad: drive_cfgs.iter().map(|d| d.counts_per_rad).collect(),
            node_ids: drive_cfgs.iter().map(|d| d.node_id).collect(),
            rated_torque_nm: drive_cfgs.iter().map(|d| d.rated_torque_nm).collect(),
            encoders,
            quantized,
            encoder_faults: vec![None; offsets.len()],
            in_flight: vec![InFlight::new(); n_drives],
            encoder_offset_rad: offsets,
            noise_rad: sim.encoder_noise_rad,
            loss_rate: sim.can_loss_rate,
            loss_mode: sim.can_loss_mode,
            spi_latency_s: sim.spi_latency_s,
            can_latency_s: sim.can_latency_s,
            can_feedback_latency_s: sim.can_feedback_latency_s.unwrap_or(sim.can_latency_s),
            substep_s: sim.substep_s,
            rng: SplitMix64(sim.seed ^ 0x9e37_79b9_7f4a_7c15),
            time_s: 0.0,
            positions: vec![0.0; n_drives],
            velocities: vec![0.0; n_drives],
            loads: vec![0.0; n_drives],
            free_arm,
        };
        for u in &mut hal.units {
            u.start(&hal.positions);
        }
        hal.record_positions();
        Ok(hal)
    }
}
