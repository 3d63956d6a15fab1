//! `jointctl inspect top`: a refreshing terminal view of a running arm: its loop (measured rate,
//! lateness percentiles, overruns), its joints (`inspect joints`) and its devices' losses.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use jointctl_ipc::wire::ByteRecord;
use jointctl_ipc::{ArmState, Diagnostics, JITTER_BUCKET_UPPER_US, JointsDescriptor, decode_name};
use ratatui::Frame;
use ratatui::crossterm::event::{self, Event, KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Modifier, Style};
use ratatui::widgets::{Block, Paragraph, Row, Table};

use crate::arm_view::RunningArm;

/// The upper bound [us] of the lateness histogram bucket holding quantile `q` (0..1) of the
/// cycles; `Some(None)` when that is the open last bucket, `None` with no cycles.
pub fn lateness_quantile(histogram: &[u64; 16], q: f64) -> Option<Option<u64>> {
    let total: u64 = histogram.iter().sum();
    if total == 0 {
        return None;
    }
    let rank = (q * total as f64).ceil().max(1.0) as u64;
    let mut seen = 0;
    for (n, upper) in histogram.iter().zip(JITTER_BUCKET_UPPER_US) {
        seen += n;
        if seen >= rank {
            return Some((upper != u64::MAX).then_some(upper));
        }
    }
    Some(None)
}

fn quantile_text(histogram: &[u64; 16], q: f64) -> String {
    match lateness_quantile(histogram, q) {
        None => "-".into(),
        Some(Some(upper)) => format!("<= {upper} us"),
        Some(None) => format!("> {} us", JITTER_BUCKET_UPPER_US[14]),
    }
}

/// What the view shows: the newest samples and the measured loop rate.
pub struct TopView {
    /// The arm.
    pub arm: String,
    /// Its plugin instances.
    pub instances: JointsDescriptor,
    /// The newest joint state.
    pub state: ArmState,
    /// The newest diagnostics.
    pub diagnostics: Diagnostics,
    /// Cycles per second over the last refresh interval [Hz], once two samples were seen.
    pub measured_rate_hz: Option<f64>,
    /// No sample for longer than the timeout.
    pub silent_s: Option<f64>,
}

/// Draws the view into a frame.
pub fn draw(frame: &mut Frame, view: &TopView) {
    let d = &view.diagnostics;
    let [header, joints, devices] = Layout::vertical([Constraint::Length(6), Constraint::Min(6), Constraint::Length(3 + d.devices.len().min(12) as u16)]).areas(frame.area());
    let nominal_hz = if d.period_ns > 0 { 1e9 / d.period_ns as f64 } else { f64::NAN };
    let rate = view.measured_rate_hz.map_or_else(|| "measuring".to_string(), |r| format!("{r:.1} Hz"));
    let silence = view.silent_s.map_or_else(String::new, |s| format!("   NO SAMPLE FOR {s:.1} s"));
    let lines = [
        format!("arm {}   cycle {}   rate {rate} (nominal {nominal_hz:.1} Hz){silence}", view.arm, d.cycle),
        format!("lateness p50 {}  p99 {}  p99.9 {}  max {:.1} us", quantile_text(&d.jitter_histogram, 0.5), quantile_text(&d.jitter_histogram, 0.99), quantile_text(&d.jitter_histogram, 0.999), d.max_jitter_ns as f64 / 1e3),
        format!("compute last {:.1} us  max {:.1} us", d.last_compute_ns as f64 / 1e3, d.max_compute_ns as f64 / 1e3),
        format!("overruns {}  missed deadlines {}  HAL errors {}  publish drops {}", d.overruns, d.missed_deadlines, d.hal_errors, d.publish_drops),
    ];
    frame.render_widget(Paragraph::new(lines.join("\n")).block(Block::bordered().title(" jointctl inspect top (q quits) ")), header);

    let view_json = crate::arm_view::joints_json(&view.instances, &view.state, d);
    let empty = Vec::new();
    let mut rows = Vec::new();
    for j in view_json["joints"].as_array().unwrap_or(&empty) {
        for dof in j["dofs"].as_array().unwrap_or(&empty) {
            let name = dof["name"].as_str().unwrap_or("?");
            let sample = view.state.joints().iter().find(|s| decode_name(&s.name) == name);
            let value = |v: Option<f64>| v.filter(|x| x.is_finite()).map_or_else(|| "-".to_string(), |x| format!("{x:.3}"));
            let yes = |v: &serde_json::Value| if v.as_bool() == Some(true) { "yes" } else { "no" };
            rows.push(Row::new(vec![
                j["name"].as_str().unwrap_or("?").to_string(),
                format!("{} {}", j["plugin"].as_str().unwrap_or("?"), j["version"].as_str().unwrap_or("")),
                name.to_string(),
                dof["mode"].as_str().unwrap_or("?").to_string(),
                yes(&dof["enabled"]).to_string(),
                yes(&dof["valid"]).to_string(),
                yes(&dof["held"]).to_string(),
                value(sample.and_then(|s| s.get(jointctl_ipc::FieldMask::POSITION, s.position_rad))),
                value(sample.and_then(|s| s.get(jointctl_ipc::FieldMask::TORQUE, s.torque_nm))),
                value(sample.map(|s| s.reference_torque_nm)),
                match dof["fault_code"].as_u64().unwrap_or(0) {
                    0 => "-".to_string(),
                    code => format!("code {code}: {}", dof["fault_message"].as_str().unwrap_or("")),
                },
            ]));
        }
    }
    let widths = [5, 8, 3, 6, 4, 3, 3, 5, 6, 5, 16].map(Constraint::Fill);
    let header_row = Row::new(["joint", "plugin", "dof", "mode", "enabled", "valid", "held", "pos [rad]", "torque [Nm]", "ref [Nm]", "fault"]).style(Style::new().add_modifier(Modifier::BOLD));
    frame.render_widget(Table::new(rows, widths).header(header_row).block(Block::bordered().title(" joints ")), joints);

    let device_rows = d.devices.iter().map(|dev| {
        Row::new(vec![decode_name(&dev.name).to_string(), dev.missing.to_string(), dev.invalid.to_string(), dev.implausible.to_string(), dev.emcy.to_string()])
    });
    let widths = [Constraint::Fill(4), Constraint::Fill(1), Constraint::Fill(1), Constraint::Fill(1), Constraint::Fill(1)];
    let header_row = Row::new(["device", "missing", "invalid", "implausible", "emcy"]).style(Style::new().add_modifier(Modifier::BOLD));
    frame.render_widget(Table::new(device_rows, widths).header(header_row).block(Block::bordered().title(" devices ")), devices);
}

/// Runs the view until q, Esc or Ctrl-C.
pub fn run(at: RunningArm, interval_s: f64, timeout_s: f64) -> ExitCode {
    if !std::io::IsTerminal::is_terminal(&std::io::stdout()) {
        return crate::fail("inspect top needs a terminal; `inspect joints --json` and `inspect diag --json` print the same once");
    }
    let instances = match crate::arm_view::newest_of(&at, timeout_s, |n| n.joints.clone(), jointctl_ipc::joints_service) {
        Ok(i) => i,
        Err(e) => return crate::fail(e),
    };
    let subscribed = crate::arm_view::subscription_of(&at, timeout_s, |n| n.joint_state.clone(), jointctl_ipc::joint_state_service)
        .and_then(|s| Ok((s, crate::arm_view::subscription_of(&at, timeout_s, |n| n.diagnostics.clone(), jointctl_ipc::diagnostics_service)?)));
    let ((_state_node, states), (_diag_node, diagnostics)) = match subscribed {
        Ok(s) => s,
        Err(e) => return crate::fail(e),
    };
    let mut view = TopView { arm: at.arm.clone(), instances, state: ArmState::EMPTY, diagnostics: Diagnostics::EMPTY, measured_rate_hz: None, silent_s: None };
    let mut terminal = ratatui::init();
    let mut last_sample = Instant::now();
    let mut rate_from: Option<(Instant, u64)> = None;
    let outcome = loop {
        while let Ok(Some(s)) = states.receive() {
            view.state.copy_from_parts(s.user_header(), s.payload());
        }
        let mut got = false;
        while let Ok(Some(d)) = diagnostics.receive() {
            // A sample whose payload disagrees with its header is skipped, never shown.
            if view.diagnostics.copy_from_parts(d.user_header(), d.payload()).is_err() {
                continue;
            }
            got = true;
        }
        let now = Instant::now();
        if got {
            last_sample = now;
            view.silent_s = None;
            match rate_from {
                Some((at, cycle)) if now.duration_since(at).as_secs_f64() >= interval_s => {
                    view.measured_rate_hz = Some(view.diagnostics.cycle.saturating_sub(cycle) as f64 / now.duration_since(at).as_secs_f64());
                    rate_from = Some((now, view.diagnostics.cycle));
                }
                Some(_) => {}
                None => rate_from = Some((now, view.diagnostics.cycle)),
            }
        } else if last_sample.elapsed().as_secs_f64() > timeout_s {
            view.silent_s = Some(last_sample.elapsed().as_secs_f64());
        }
        if let Err(e) = terminal.draw(|f| draw(f, &view)) {
            break Err(format!("cannot draw: {e}"));
        }
        match event::poll(Duration::from_secs_f64(interval_s)) {
            Ok(true) => match event::read() {
                Ok(Event::Key(k)) if k.code == KeyCode::Char('q') || k.code == KeyCode::Esc || (k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL)) => break Ok(()),
                Ok(_) => {}
                Err(e) => break Err(format!("cannot read the terminal: {e}")),
            },
            Ok(false) => {}
            Err(e) => break Err(format!("cannot read the terminal: {e}")),
        }
    };
    ratatui::restore();
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => crate::fail(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_the_bucket_bounds_that_hold_them() {
        let mut h = [0u64; 16];
        assert_eq!(lateness_quantile(&h, 0.5), None);
        h[2] = 99; // 2-5 us
        h[9] = 1; // 500-1000 us
        assert_eq!(lateness_quantile(&h, 0.5), Some(Some(5)));
        assert_eq!(lateness_quantile(&h, 0.99), Some(Some(5)));
        assert_eq!(lateness_quantile(&h, 0.999), Some(Some(1000)));
        h[15] = 100;
        assert_eq!(lateness_quantile(&h, 0.99), Some(None), "the open last bucket");
    }

    #[test]
    fn the_view_shows_the_loop_the_joints_and_the_devices() {
        let mut instances = JointsDescriptor::EMPTY;
        instances.joints.push(jointctl_ipc::JointDescriptor {
            name: jointctl_ipc::encode_name("elbow"),
            plugin: jointctl_ipc::encode_name("elastic"),
            version: jointctl_ipc::encode_name("0.1.0"),
            dof_count: 1,
            ..jointctl_ipc::JointDescriptor::EMPTY
        });
        let mut state = ArmState::EMPTY;
        state.joints.push(jointctl_ipc::JointSample::EMPTY);
        state.joints[0].name = jointctl_ipc::encode_name("q4");
        state.joints[0].torque_nm = 1.25;
        state.joints[0].valid_mask = jointctl_ipc::FieldMask::TORQUE;
        state.joints[0].fault_code = 42;
        let mut diagnostics = Diagnostics::EMPTY;
        diagnostics.cycle = 1234;
        diagnostics.period_ns = 1_000_000;
        diagnostics.overruns = 3;
        diagnostics.jitter_histogram[3] = 10; // 5-10 us
        diagnostics.joints.push(jointctl_ipc::JointDiagnostics::EMPTY);
        diagnostics.joints[0].name = state.joints[0].name;
        diagnostics.joints[0].fault_message = jointctl_ipc::encode_name("spring broke");
        diagnostics.devices.push(jointctl_ipc::DeviceDiagnostics::EMPTY);
        diagnostics.devices[0].name = jointctl_ipc::encode_name("enc_elbow_output");
        diagnostics.devices[0].missing = 7;
        let view = TopView { arm: "sherpa".into(), instances, state, diagnostics, measured_rate_hz: Some(999.5), silent_s: None };
        let mut terminal = ratatui::Terminal::new(ratatui::backend::TestBackend::new(140, 20)).unwrap();
        terminal.draw(|f| draw(f, &view)).unwrap();
        let text: String = terminal.backend().buffer().content().iter().map(|c| c.symbol()).collect();
        for expected in ["cycle 1234", "999.5 Hz", "nominal 1000.0 Hz", "p50 <= 10 us", "overruns 3", "elbow", "elastic 0.1.0", "q4", "1.250", "code 42: spring broke", "enc_elbow_output", "7"] {
            assert!(text.contains(expected), "`{expected}` missing from:\n{text}");
        }
    }
}
