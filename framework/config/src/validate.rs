//! Checks that need the whole document: names, references, ranges, consistency.

use std::collections::{HashMap, HashSet};

use crate::model::{ArmConfig, LimitsConfig};

/// Bounds on any arm description (published or not).
pub use jointctl_api::{MAX_LOOP_DEVICES, MAX_LOOP_DOF};
/// Longest joint name (it is published in a fixed 16-byte field, NUL-terminated).
pub use jointctl_api::MAX_JOINT_NAME;

/// The command kinds a network section may allow, by name: `jointctl_ipc::CommandKind`'s (the
/// config does not link the shared-memory crate; the bridge's tests check the two lists agree).
pub const COMMAND_KINDS: [&str; 10] = ["hold", "position", "manual", "trajectory", "torque", "impedance", "stiffness", "enable", "disable", "stop"];

fn valid_name(s: &str, max: usize) -> bool {
    !s.is_empty() && s.len() <= max && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// The largest limits a joint description may state: beyond them a value is a typo (a unit
/// mix-up), not a joint. Each is an assumption with its reason.
struct Plausible {
    /// Two turns either way [rad]: the thesis gives no joint ranges; a wider range than two
    /// turns is almost surely degrees written for radians.
    position_rad: f64,
    /// 50 rad/s at the joint: about 8 turns per second, far beyond an ELMO-driven harmonic
    /// drive joint of this class.
    velocity_rad_s: f64,
    /// 1000 Nm: 25 times q2's 40 Nm limit in the reference config, beyond any joint of a
    /// 7-DOF rover arm; 1e12 Nm is a typo.
    torque_nm: f64,
    /// 1e6 Nm/rad: above the rigid joints' 8.3e4 Nm/rad (section 3.1).
    stiffness_nm_per_rad: f64,
}

const PLAUSIBLE: Plausible =
    Plausible { position_rad: 4.0 * core::f64::consts::PI, velocity_rad_s: 50.0, torque_nm: 1000.0, stiffness_nm_per_rad: 1e6 };

fn device_name_problem(name: &str) -> String {
    format!("`{name}` is not a valid device name: use 1-{} letters, digits, `_` or `-`", jointctl_api::MAX_DEVICE_NAME)
}

/// Every semantic problem as (field path, message).
pub(crate) fn validate(c: &ArmConfig) -> Vec<(String, String)> {
    let mut errs = Vec::new();
    let mut err = |path: String, msg: String| errs.push((path, msg));

    if !valid_name(&c.arm, 32) {
        err("arm".into(), format!("`{}` is not a valid arm name: use 1-32 letters, digits, `_` or `-`", c.arm));
    }
    // At least 1 Hz (an assumption: a torque loop slower than that cannot hold a joint, and the
    // runtime answers SIGINT and commands once a period: at 1e-6 Hz it never would, and at
    // 1e-300 Hz the period is not a time at all).
    if !(c.rate_hz >= 1.0 && c.rate_hz <= 10_000.0) {
        err("rate_hz".into(), format!("must be in [1, 10000] Hz, got {}", crate::short_number(c.rate_hz)));
    }
    if let Some(k) = &c.kinematics
        && !(k.gravity_m_s2 >= 0.0 && k.gravity_m_s2 <= 30.0)
    {
        // Assumption: 0-30 m/s^2 covers every body a rover arm works on (Earth 9.81, Mars 3.71).
        err("kinematics.gravity_m_s2".into(), format!("must be 0-30 m/s^2, got {}", k.gravity_m_s2));
    }
    let sim = &c.hal.sim;
    if sim.encoder_noise_rad < 0.0 {
        err("hal.sim.encoder_noise_rad".into(), format!("must be >= 0, got {}", sim.encoder_noise_rad));
    }
    if !(0.0..=1.0).contains(&sim.can_loss_rate) {
        err("hal.sim.can_loss_rate".into(), format!("must be a fraction 0-1, got {}", sim.can_loss_rate));
    }
    if !(sim.spi_latency_s >= 0.0 && sim.spi_latency_s <= 0.1) {
        err("hal.sim.spi_latency_s".into(), format!("must be 0-0.1 s, got {}", sim.spi_latency_s));
    }
    if !(sim.can_latency_s >= 0.0 && sim.can_latency_s <= 0.1) {
        err("hal.sim.can_latency_s".into(), format!("must be 0-0.1 s, got {}", sim.can_latency_s));
    }
    if let Some(l) = sim.can_feedback_latency_s
        && !(0.0..=0.1).contains(&l)
    {
        err("hal.sim.can_feedback_latency_s".into(), format!("must be 0-0.1 s, got {l}"));
    }
    if !(sim.substep_s >= 1e-5 && sim.substep_s <= 0.005) {
        err("hal.sim.substep_s".into(), format!("must be 1e-5 to 5e-3 s, got {}", sim.substep_s));
    }
    let e = &sim.elmo;
    for (name, v) in [
        ("max_velocity_rad_s", e.max_velocity_rad_s),
        ("max_acceleration_rad_s2", e.max_acceleration_rad_s2),
        ("inertia_kgm2", e.inertia_kgm2),
        ("torque_limit_nm", e.torque_limit_nm),
    ] {
        if v <= 0.0 {
            err(format!("hal.sim.elmo.{name}"), format!("must be > 0, got {v}"));
        }
    }
    if let Some(p) = c.timing.realtime_priority
        && !(1..=99).contains(&p)
    {
        err("timing.realtime_priority".into(), format!("must be 1-99, got {p}"));
    }
    let budget = c.timing.joint_budget_fraction;
    if !(budget > 0.0 && budget <= 1.0) {
        err("timing.joint_budget_fraction".into(), format!("must be a fraction of the period in (0, 1], got {budget}"));
    }
    if c.timing.joint_budget_strikes == 0 {
        err("timing.joint_budget_strikes".into(), "must be >= 1".into());
    }
    for (j, joint) in c.joints.iter().enumerate() {
        if let Some(b) = joint.budget_us
            && !(b > 0.0 && b <= 1e6 / c.rate_hz)
        {
            err(format!("joints[{j}].budget_us"), format!("must be > 0 and at most the period ({} us), got {b}", 1e6 / c.rate_hz));
        }
    }
    for (name, v) in [("max_subscribers", c.ipc.max_subscribers), ("max_clients", c.ipc.max_clients)] {
        if !(1..=256).contains(&v) {
            err(format!("ipc.{name}"), format!("must be 1-256, got {v}"));
        }
    }
    if let Some(d) = &c.ipc.domain
        && !valid_name(d, 32)
    {
        err("ipc.domain".into(), format!("`{d}` is not a valid domain: use 1-32 letters, digits, `_` or `-`"));
    }

    if let Some(z) = &c.network.zenoh.commands {
        let form = z.listen.split_once('/').filter(|(protocol, address)| !protocol.is_empty() && address.contains(':'));
        if form.is_none() {
            err("network.zenoh.commands.listen".into(), format!("`{}` is not a Zenoh endpoint: write <protocol>/<address>:<port>, e.g. tcp/0.0.0.0:7448", z.listen));
        }
        if !(z.max_commands_per_s >= 0.1 && z.max_commands_per_s <= 1000.0) {
            err("network.zenoh.commands.max_commands_per_s".into(), format!("must be in [0.1, 1000] commands a second, got {}", crate::short_number(z.max_commands_per_s)));
        }
    }

    if c.network.ros2.domain_id > 232 {
        err("network.ros2.domain_id".into(), format!("must be 0-232 (the DDS domains RTPS maps to UDP ports), got {}", c.network.ros2.domain_id));
    }
    if let Some(r) = &c.network.ros2.commands {
        if r.allow.is_empty() {
            err("network.ros2.commands.allow".into(), "names no command kind: list what ROS 2 may send (e.g. [trajectory, hold]), or remove `commands`".into());
        }
        for (i, kind) in r.allow.iter().enumerate() {
            if !COMMAND_KINDS.contains(&kind.as_str()) {
                err(format!("network.ros2.commands.allow[{i}]"), format!("unknown command kind `{kind}` (one of {})", COMMAND_KINDS.join(", ")));
            }
        }
        if !(r.max_commands_per_s >= 0.1 && r.max_commands_per_s <= 1000.0) {
            err("network.ros2.commands.max_commands_per_s".into(), format!("must be in [0.1, 1000] commands a second, got {}", crate::short_number(r.max_commands_per_s)));
        }
    }

    // CiA 402: from "quick stop active" a drive goes on only to "switch on disabled" (or back to
    // operation enabled); it ignores "disable operation".
    if let Some(i) = c.safety.stop_sequence.windows(2).position(|w| w == [crate::StopStep::QuickStop, crate::StopStep::DisableOperation]) {
        err(format!("safety.stop_sequence[{}]", i + 1), "a drive in quick stop does not take disable_operation (CiA 402); use disable_voltage after quick_stop".into());
    }
    if !(0.01..=10.0).contains(&c.safety.stop_step_timeout_s) {
        err("safety.stop_step_timeout_s".into(), format!("must be in [0.01, 10] s, got {}", crate::short_number(c.safety.stop_step_timeout_s)));
    }
    let co = &c.hal.canopen;
    if !(1..=127).contains(&co.host_node_id) {
        err("hal.canopen.host_node_id".into(), format!("a CANopen node id is 1-127, got {}", co.host_node_id));
    }
    for (field, value) in [("heartbeat_timeout_s", co.heartbeat_timeout_s), ("heartbeat_grace_s", co.heartbeat_grace_s)] {
        if let Some(v) = value
            && !(0.001..=60.0).contains(&v)
        {
            err(format!("hal.canopen.{field}"), format!("must be in [0.001, 60] s, got {}", crate::short_number(v)));
        }
    }
    if co.host_heartbeat_ms == 0 || co.comm_loss_timeout_ms <= co.host_heartbeat_ms {
        err(
            "hal.canopen.comm_loss_timeout_ms".into(),
            format!("must exceed host_heartbeat_ms ({} ms) > 0, got {} ms", co.host_heartbeat_ms, co.comm_loss_timeout_ms),
        );
    }
    // Devices: unique names across all buses; node ids and chip selects unique per bus.
    let mut devices: HashMap<&str, String> = HashMap::new();
    let mut drive_names = HashSet::new();
    let mut encoder_names = HashSet::new();
    for (b, bus) in c.buses.can.iter().enumerate() {
        if !(10_000..=1_000_000).contains(&bus.bitrate) {
            err(format!("buses.can[{b}].bitrate"), format!("must be 10000-1000000 bit/s, got {}", bus.bitrate));
        }
        let mut ids = HashMap::new();
        for (i, d) in bus.drives.iter().enumerate() {
            let path = format!("buses.can[{b}].drives[{i}]");
            if let Some(first) = devices.insert(&d.name, path.clone()) {
                err(format!("{path}.name"), format!("device `{}` is already defined at {first}", d.name));
            }
            if !valid_name(&d.name, jointctl_api::MAX_DEVICE_NAME) {
                err(format!("{path}.name"), device_name_problem(&d.name));
            }
            drive_names.insert(d.name.as_str());
            if !(d.counts_per_rad > 0.0) {
                err(format!("{path}.counts_per_rad"), format!("must be > 0, got {}", d.counts_per_rad));
            }
            if !(d.max_velocity_rad_s > 0.0) {
                err(format!("{path}.max_velocity_rad_s"), format!("must be > 0, got {}", d.max_velocity_rad_s));
            }
            if let Some([lo, hi]) = d.setpoint_window_rad {
                if !(lo < hi) {
                    err(format!("{path}.setpoint_window_rad"), format!("lower end {} must be below upper end {}", crate::short_number(lo), crate::short_number(hi)));
                } else if lo.abs().max(hi.abs()) * d.counts_per_rad > f64::from(i32::MAX) {
                    // Written to the drive as 32-bit counts (0x607D).
                    err(format!("{path}.setpoint_window_rad"), format!("does not fit the drive's 32-bit counts at {} counts/rad", crate::short_number(d.counts_per_rad)));
                }
            }
            if let Some(w) = d.limits.following_error_window_rad
                && w * d.counts_per_rad < 1.0
            {
                err(format!("{path}.limits.following_error_window_rad"), format!("{} rad is less than one count: the drive would fault on every cycle", crate::short_number(w)));
            }
            for (name, value) in [
                ("max_profile_velocity_rad_s", d.limits.max_profile_velocity_rad_s),
                ("following_error_window_rad", d.limits.following_error_window_rad),
                ("quick_stop_deceleration_rad_s2", d.limits.quick_stop_deceleration_rad_s2),
            ] {
                // In counts, each must fit the object's 32 bits.
                if let Some(v) = value
                    && !(v > 0.0 && v * d.counts_per_rad <= f64::from(u32::MAX))
                {
                    err(format!("{path}.limits.{name}"), format!("must be > 0 and at most {} in counts, got {}", u32::MAX, crate::short_number(v)));
                }
            }
            if let Some(p) = d.limits.max_torque_permille
                && p == 0
            {
                err(format!("{path}.limits.max_torque_permille"), "must be > 0 (0 allows no torque)".into());
            }
            if let Some(r) = d.rated_torque_nm
                && !(r > 0.0 && r <= 1e6)
            {
                err(format!("{path}.rated_torque_nm"), format!("must be in (0, 1e6] Nm, got {}", crate::short_number(r)));
            }
            if let Some(r) = d.max_setpoint_rate_rad_s
                && !(r > 0.0 && r <= 1000.0)
            {
                err(format!("{path}.max_setpoint_rate_rad_s"), format!("must be in (0, 1000] rad/s, got {}", crate::short_number(r)));
            }
            if d.heartbeat_ms == 0 {
                err(format!("{path}.heartbeat_ms"), "must be > 0 (the heartbeat tells a silent drive)".into());
            }
            if !(1..=127).contains(&d.node_id) {
                err(format!("{path}.node_id"), format!("a CANopen node id is 1-127, got {}", d.node_id));
            } else if let Some(other) = ids.insert(d.node_id, d.name.as_str()) {
                err(format!("{path}.node_id"), format!("node id {} is already used by `{other}` on this bus", d.node_id));
            } else if d.node_id == co.host_node_id {
                err(format!("{path}.node_id"), format!("node id {} is the host's (hal.canopen.host_node_id)", d.node_id));
            }
        }
    }
    for (b, bus) in c.buses.spi.iter().enumerate() {
        let mut cs = HashMap::new();
        for (i, e) in bus.encoders.iter().enumerate() {
            let path = format!("buses.spi[{b}].encoders[{i}]");
            if let Some(first) = devices.insert(&e.name, path.clone()) {
                err(format!("{path}.name"), format!("device `{}` is already defined at {first}", e.name));
            }
            if !valid_name(&e.name, jointctl_api::MAX_DEVICE_NAME) {
                err(format!("{path}.name"), device_name_problem(&e.name));
            }
            encoder_names.insert(e.name.as_str());
            if !(e.max_velocity_rad_s > 0.0) {
                err(format!("{path}.max_velocity_rad_s"), format!("must be > 0, got {}", e.max_velocity_rad_s));
            }
            if e.chip_select > 15 {
                err(format!("{path}.chip_select"), format!("must be 0-15, got {}", e.chip_select));
            } else if let Some(other) = cs.insert(e.chip_select, e.name.as_str()) {
                err(format!("{path}.chip_select"), format!("chip select {} is already used by `{other}`", e.chip_select));
            }
        }
    }
    let mut torque_sensor_names = HashSet::new();
    for (i, f) in c.buses.force_torque.iter().enumerate() {
        let path = format!("buses.force_torque[{i}]");
        if let Some(first) = devices.insert(&f.name, path.clone()) {
            err(format!("{path}.name"), format!("device `{}` is already defined at {first}", f.name));
        }
        if !valid_name(&f.name, jointctl_api::MAX_DEVICE_NAME) {
            err(format!("{path}.name"), device_name_problem(&f.name));
        }
        torque_sensor_names.insert(f.name.as_str());
        if !(f.axis.iter().map(|a| a * a).sum::<f64>() > 1e-12) {
            err(format!("{path}.axis"), format!("must be a direction (not zero), got {:?}", f.axis));
        }
        if !(f.range_nm > 0.0) {
            err(format!("{path}.range_nm"), format!("must be > 0, got {}", f.range_nm));
        }
        if let Some(n) = &f.netft {
            if !n.address.rsplit_once(':').is_some_and(|(host, port)| !host.is_empty() && port.parse::<u16>().is_ok_and(|p| p > 0)) {
                err(format!("{path}.netft.address"), format!("must be HOST:PORT (ATI's default 192.168.1.1:49152), got `{}`", n.address));
            }
            for (field, v) in [("counts_per_force", n.counts_per_force), ("counts_per_torque", n.counts_per_torque), ("timeout_s", n.timeout_s)] {
                if !(v > 0.0) {
                    err(format!("{path}.netft.{field}"), format!("must be > 0, got {v}"));
                }
            }
        }
    }
    if c.buses.force_torque.len() > MAX_LOOP_DEVICES {
        err("buses.force_torque".into(), format!("{} force/torque sensors exceed the maximum of {MAX_LOOP_DEVICES}", c.buses.force_torque.len()));
    }
    for (j, joint) in c.joints.iter().enumerate() {
        if !joint.dofs.is_empty() && joint.torque_sensor.is_some() {
            err(format!("joints[{j}].torque_sensor"), "with `dofs`, give each DOF its `torque_sensor` under `dofs[i]`".into());
            continue;
        }
        for (field, sensor) in joint.dof_torque_sensors() {
            if let Some(s) = sensor.filter(|s| !torque_sensor_names.contains(s)) {
                err(format!("joints[{j}].{field}"), format!("no force/torque sensor named `{s}` is defined under buses.force_torque"));
            }
        }
    }
    for (b, bus) in c.buses.spi.iter().enumerate() {
        for (i, e) in bus.encoders.iter().enumerate() {
            let Some(s) = &e.sim else { continue };
            let path = format!("buses.spi[{b}].encoders[{i}].sim");
            let ways = s.drive.is_some() as u8 + s.fixed_rad.is_some() as u8 + !s.sum.is_empty() as u8 + s.signal.is_some() as u8;
            if ways != 1 {
                err(path.clone(), "give exactly one of `drive` (follow a drive), `sum` (weighted terms), `signal` (a simulated joint's signal) or `fixed_rad` (clamped output)".into());
            }
            if let Some(d) = s.drive.as_ref().filter(|d| !drive_names.contains(d.as_str())) {
                err(format!("{path}.drive"), format!("no drive named `{d}` is defined under buses.can"));
            }
            for (t, term) in s.sum.iter().enumerate() {
                match (&term.drive, &term.signal) {
                    (Some(d), None) if !drive_names.contains(d.as_str()) => {
                        err(format!("{path}.sum[{t}].drive"), format!("no drive named `{d}` is defined under buses.can"))
                    }
                    (Some(_), None) | (None, Some(_)) => {}
                    _ => err(format!("{path}.sum[{t}]"), "give exactly one of `drive` or `signal`".into()),
                }
            }
        }
    }

    // Joints.
    if c.joints.is_empty() {
        err("joints".into(), "an arm needs at least one joint".into());
    }
    let mut instance_names = HashMap::new();
    let mut dof_names = HashMap::new();
    let mut drive_users: HashMap<&str, String> = HashMap::new();
    let mut total_dof = 0;
    for (j, joint) in c.joints.iter().enumerate() {
        let path = format!("joints[{j}]");
        if let Some(first) = instance_names.insert(joint.name.as_str(), j) {
            err(format!("{path}.name"), format!("joint `{}` is already defined at joints[{first}]", joint.name));
        }
        if !joint.dofs.is_empty() && joint.limits.is_some() {
            err(format!("{path}.limits"), "with `dofs`, give limits per DOF under `dofs[i].limits`".into());
        }
        let names: Vec<(String, &str)> = if joint.dofs.is_empty() {
            vec![(format!("{path}.name"), joint.name.as_str())]
        } else {
            joint.dofs.iter().enumerate().map(|(d, dof)| (format!("{path}.dofs[{d}].name"), dof.name.as_str())).collect()
        };
        total_dof += names.len();
        for (p, name) in names {
            if !valid_name(name, crate::validate::MAX_JOINT_NAME) {
                err(p.clone(), format!("`{name}` is not a valid joint name: use 1-15 letters, digits, `_` or `-`"));
            }
            if let Some(first) = dof_names.insert(name, p.clone())
                && first != p
            {
                err(p, format!("joint `{name}` is already defined at {first}"));
            }
        }
        let limits: Vec<(String, &LimitsConfig)> = if joint.dofs.is_empty() {
            joint.limits.iter().map(|l| (format!("{path}.limits"), l)).collect()
        } else {
            joint
                .dofs
                .iter()
                .enumerate()
                .filter_map(|(d, dof)| dof.limits.as_ref().map(|l| (format!("{path}.dofs[{d}].limits"), l)))
                .collect()
        };
        for (p, l) in limits {
            let [lo, hi] = l.position_rad;
            if lo >= hi {
                err(format!("{p}.position_rad"), format!("lower limit {lo} must be below upper limit {hi}"));
            }
            if lo < -PLAUSIBLE.position_rad || hi > PLAUSIBLE.position_rad {
                err(format!("{p}.position_rad"), format!("[{lo}, {hi}] rad is implausible for a joint: limits must lie within +-{} rad (two turns); a typo in the units?", PLAUSIBLE.position_rad));
            }
            if let Some(v) = l.velocity_rad_s.filter(|v| !(*v > 0.0 && *v <= PLAUSIBLE.velocity_rad_s)) {
                err(format!("{p}.velocity_rad_s"), format!("must be > 0 and at most {} rad/s, got {v}", PLAUSIBLE.velocity_rad_s));
            }
            if let Some(t) = l.torque_nm.filter(|t| !(*t > 0.0 && *t <= PLAUSIBLE.torque_nm)) {
                err(format!("{p}.torque_nm"), format!("must be > 0 and at most {} Nm, got {t}", PLAUSIBLE.torque_nm));
            }
            if let Some([a, b]) = l.stiffness_nm_per_rad
                && !(a.is_finite() && b.is_finite() && a > 0.0 && a < b && b <= PLAUSIBLE.stiffness_nm_per_rad)
            {
                err(
                    format!("{p}.stiffness_nm_per_rad"),
                    format!("must be [lowest, highest] with 0 < lowest < highest <= {} Nm/rad, got [{a}, {b}]", PLAUSIBLE.stiffness_nm_per_rad),
                );
            }
        }
        if joint.dofs.is_empty() || joint.controller.is_none() {
            for (field, c) in joint.dof_controllers() {
                if let Err(e) = c.validate() {
                    err(format!("{path}.{field}.{}", e.field()), e.to_string());
                }
            }
        } else {
            err(format!("{path}.controller"), "with `dofs`, give controllers per DOF under `dofs[i].controller`".into());
        }
        for (role, dev) in &joint.encoders {
            if !encoder_names.contains(dev.as_str()) {
                err(format!("{path}.encoders.{role}"), format!("no encoder named `{dev}` is defined under buses.spi"));
            }
        }
        for (role, dev) in &joint.drives {
            if !drive_names.contains(dev.as_str()) {
                err(format!("{path}.drives.{role}"), format!("no drive named `{dev}` is defined under buses.can"));
            } else if let Some(first) = drive_users.insert(dev.as_str(), format!("{path}.drives.{role}")) {
                err(format!("{path}.drives.{role}"), format!("drive `{dev}` is already commanded by {first}; a drive has one master"));
            }
        }
    }
    // Bounds on what one runtime builds (the shared-memory samples are sized by the arm).
    if total_dof > MAX_LOOP_DOF {
        err("joints".into(), format!("{total_dof} DOFs exceed the maximum of {MAX_LOOP_DOF}"));
    }
    let encoders: usize = c.buses.spi.iter().map(|b| b.encoders.len()).sum();
    if encoders > MAX_LOOP_DEVICES {
        err("buses.spi".into(), format!("{encoders} encoders exceed the maximum of {MAX_LOOP_DEVICES}"));
    }
    let drives: usize = c.buses.can.iter().map(|b| b.drives.len()).sum();
    if drives > MAX_LOOP_DEVICES {
        err("buses.can".into(), format!("{drives} drives exceed the maximum of {MAX_LOOP_DEVICES}"));
    }
    errs
}
