//! Building an arm from its YAML: each joint's plugin loaded, its roles wired to devices, its
//! instance created and configured; every problem reported at its place in the YAML.

use jointctl_api::{JointContext, MAX_DOF, MAX_DRIVES, MAX_ENCODERS};
use jointctl_config::{ConfigError, ConfigErrors, ConfigSource, JointConfig, LoadedConfig};
use jointctl_hal::{DeviceIndex, Hal};

use super::*;

fn roles(text: &str) -> Vec<(&str, bool)> {
    text.split(',').filter(|r| !r.is_empty()).map(|r| match r.strip_suffix('?') {
        Some(name) => (name, false),
        None => (r, true),
    }).collect()
}


/// Each encoder role's and each drive role's device index in the frames.
type RoleMaps = ([Option<usize>; MAX_ENCODERS], [Option<usize>; MAX_DRIVES]);

/// Maps a joint's wired devices onto its plugin's roles: `(encoder_map, drive_map)`, each role's
/// device index in the frames. Unknown roles and unwired required roles are errors at their
/// place in the YAML; `None` when there was any.
fn wire(
    jc: &JointConfig,
    enc_roles: &[(&str, bool)],
    drv_roles: &[(&str, bool)],
    devices: &DeviceIndex,
    at: &dyn Fn(&str) -> String,
    src: &ConfigSource,
    errors: &mut Vec<ConfigError>,
) -> Option<RoleMaps> {
    let mut encoder_map = [None; MAX_ENCODERS];
    let mut drive_map = [None; MAX_DRIVES];
    let mut wiring_ok = true;
    for (kind, wired, declared, lookup, map) in [
        ("encoder", &jc.encoders, enc_roles, &devices.encoders, &mut encoder_map[..]),
        ("drive", &jc.drives, drv_roles, &devices.drives, &mut drive_map[..]),
    ] {
        let field = if kind == "encoder" { "encoders" } else { "drives" };
        for role in wired.keys() {
            if !declared.iter().any(|(r, _)| r == role) {
                let list: Vec<_> = declared.iter().map(|(r, _)| *r).collect();
                errors.push(src.error(
                    &at(&format!("{field}.{role}")),
                    format!("plugin `{}` has no {kind} role `{role}`; its roles are: {}", jc.plugin.name, list.join(", ")),
                ));
                wiring_ok = false;
            }
        }
        for (i, (role, required)) in declared.iter().enumerate() {
            match wired.get(*role) {
                Some(dev) => map[i] = lookup.iter().position(|n| n == dev),
                None if *required => {
                    errors.push(src.error(&at(field), format!("plugin `{}` needs {kind} role `{role}` wired to a device", jc.plugin.name)));
                    wiring_ok = false;
                }
                None => {}
            }
        }
    }
    wiring_ok.then_some((encoder_map, drive_map))
}

/// Creates and configures a joint's plugin instance; an error names the param it concerns.
fn instantiate(
    jc: &JointConfig,
    source: PluginSource,
    ctx: &JointContext,
    at: &dyn Fn(&str) -> String,
    src: &ConfigSource,
) -> Result<FfiJoint, ConfigError> {
    let params = if jc.params.0.is_null() { "{}".to_string() } else { jc.params.0.to_string() };
    let located = |e: jointctl_api::PluginError| {
        let field = e.field.as_ref().map_or_else(|| at("params"), |f| at(&format!("params.{f}")));
        src.error(&field, format!("plugin `{}`: {}", jc.plugin.name, e.message))
    };
    let mut joint = FfiJoint::create(source, &params).map_err(located)?;
    joint.configure(ctx).map_err(located)?;
    Ok(joint)
}

impl Arm {
    /// Loads every joint's plugin, wires it and creates and configures its instance. Every
    /// problem is reported at its place in the YAML.
    pub fn build(loaded: &LoadedConfig, loader: &PluginLoader, hal: Box<dyn Hal>) -> Result<Arm, ConfigErrors> {
        let cfg = &loaded.config;
        let src = &loaded.source;
        let devices = DeviceIndex::of(cfg);
        let mut errors = Vec::new();
        let mut slots = Vec::new();
        let mut dof_names = Vec::new();
        let mut limits = Vec::new();
        let mut controllers = Vec::new();
        let mut capabilities = Vec::new();
        let mut torque_sensor_of = Vec::new();
        for (j, jc) in cfg.joints.iter().enumerate() {
            let at = |field: &str| if field.is_empty() { format!("joints[{j}]") } else { format!("joints[{j}].{field}") };
            let path = jc.plugin.path.as_ref().map(|p| src.resolve(p));
            let source = match loader.load(&jc.plugin.name, path.as_deref()) {
                Ok(s) => s,
                Err(e) => {
                    errors.push(src.error(&at("plugin"), e.to_string()));
                    continue;
                }
            };
            let d = source.descriptor;
            let names = jc.dof_names();
            let (enc_roles, drv_roles) = (roles(d.encoder_roles()), roles(d.drive_roles()));
            if d.dof() as usize != names.len() || names.len() > MAX_DOF {
                errors.push(src.error(
                    &at(if jc.dofs.is_empty() { "name" } else { "dofs" }),
                    format!(
                        "plugin `{}` serves {} DOF(s) per instance, the YAML gives {}{}",
                        jc.plugin.name,
                        d.dof(),
                        names.len(),
                        if d.dof() > 1 { ": name each under `dofs`" } else { "" }
                    ),
                ));
                continue;
            }
            let Some((encoder_map, drive_map)) = wire(jc, &enc_roles, &drv_roles, &devices, &at, src, &mut errors) else {
                continue;
            };
            let ctx = JointContext::new(d.dof(), enc_roles.len() as u32, drv_roles.len() as u32, cfg.rate_hz);
            let plugin_library = source.library.clone();
            let joint = match instantiate(jc, source, &ctx, &at, src) {
                Ok(j) => j,
                Err(e) => {
                    errors.push(e);
                    continue;
                }
            };
            let first = dof_names.len();
            dof_names.extend(names.iter().map(|n| n.to_string()));
            capabilities.extend((0..names.len()).map(|i| (d.observes_torque(i), d.sets_stiffness(i))));
            torque_sensor_of.extend(jc.dof_torque_sensors().into_iter().map(|(_, s)| s.and_then(|s| devices.torque_sensor(s))));
            for (l, (_, c)) in jc.dof_limits().into_iter().zip(jc.dof_controllers()) {
                let dof_limits = l.map_or(DofLimits::NONE, |l| DofLimits {
                    position_rad: l.position_rad,
                    torque_nm: l.torque_nm.unwrap_or(f64::INFINITY),
                    velocity_rad_s: l.velocity_rad_s.unwrap_or(f64::INFINITY),
                });
                controllers.push(JointController::new(c, dof_limits));
                limits.push(l);
            }
            slots.push(JointSlot {
                name: jc.name.clone(),
                plugin: jc.plugin.name.clone(),
                plugin_version: d.version().to_string(),
                plugin_library,
                joint: Box::new(joint),
                dofs: first..dof_names.len(),
                encoder_map,
                drive_map,
                drive_count: drv_roles.len(),
                raw: RawJointView::default(),
                setpoints: [MotorSetpoint::HOLD; MAX_DRIVES],
                fault: 0,
                fault_count: 0,
                invalid_cycles: 0,
                held: false,
                fault_unreported: false,
                budget_ns: (jc.budget_us.unwrap_or(cfg.timing.joint_budget_fraction * 1e6 / cfg.rate_hz) * 1e3) as u64,
                used_ns: 0,
                max_used_ns: 0,
                stall_limit_ns: ((1e9 / cfg.rate_hz) as u64).max(u64::from(cfg.timing.joint_stall_floor_us) * 1000),
                strikes_allowed: cfg.timing.joint_budget_strikes,
                strikes: 0,
                in_budget_cycles: 0,
                forgive_after: cfg.rate_hz.ceil() as u64,
                over_budget_cycles: 0,
                setpoint_rejections: 0,
                runtime_reason: Default::default(),
                budget_enforced: true,
            });
        }
        if !errors.is_empty() {
            return Err(ConfigErrors(errors));
        }
        let n = dof_names.len();
        let gravity = ArmGravity::new(loaded, &dof_names);
        Ok(Arm {
            name: cfg.arm.clone(),
            rate_hz: cfg.rate_hz,
            dt_s: 1.0 / cfg.rate_hz,
            slots,
            dof_names,
            limits,
            capabilities,
            states: vec![JointState::UNKNOWN; n],
            commands: vec![JointCommand::HOLD; n],
            controllers,
            torque_references: vec![f64::NAN; n],
            gravity_torques: vec![f64::NAN; n],
            stiffness_requests: vec![f64::NAN; n],
            enabled: vec![true; n],
            stop_requested: false,
            now_s: 0.0,
            hal_errors: 0,
            readings_ns: 0,
            sensor: SensorFrame::new(&devices),
            actuator: ActuatorFrame::new(&devices),
            hal,
            devices,
            torque_sensor_of,
            device_buses: (
                cfg.buses.spi.iter().enumerate().flat_map(|(b, bus)| bus.encoders.iter().map(move |_| b as u32)).collect(),
                cfg.buses.can.iter().enumerate().flat_map(|(b, bus)| bus.drives.iter().map(move |_| b as u32)).collect(),
            ),
            config_path: std::fs::canonicalize(&src.file).ok(),
            gravity,
            guard: crate::guard::SetpointGuard::new(cfg),
            stop_sequence: cfg.safety.stop_sequence.clone(),
            stop_step_timeout_s: cfg.safety.stop_step_timeout_s,
            shut_down: false,
        })
    }
}
