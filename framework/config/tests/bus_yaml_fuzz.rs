//! The bus sections of an arm description are parsed without a panic whatever they contain:
//! arbitrary scalars, wrong types, deep nesting, garbage text.

use proptest::prelude::*;

fn scalar() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<i64>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:e}")),
        Just(".nan".to_string()),
        Just("-.inf".to_string()),
        Just("~".to_string()),
        "[a-z_/0-9]{0,12}",
        Just("[1, [2, {a: 3}]]".to_string()),
        Just("{x: {y: {z: []}}}".to_string()),
        "[ -~]{0,20}".prop_map(|s| format!("{s:?}")),
    ]
}

proptest! {
    #[test]
    fn bus_sections_never_panic(
        iface in scalar(), bitrate in scalar(), name in scalar(), node in scalar(), cpr in scalar(),
        hb in scalar(), dev in scalar(), cs in scalar(), garbage in "[ -~\\n]{0,40}",
    ) {
        let yaml = format!(
            "arm: a\nhal: {{backend: socketcan}}\nbuses:\n  can:\n    - interface: {iface}\n      bitrate: {bitrate}\n      drives:\n        - {{name: {name}, node_id: {node}, counts_per_rad: {cpr}, heartbeat_ms: {hb}}}\n  spi:\n    - device: {dev}\n      encoders: [{{name: e, chip_select: {cs}}}]\njoints: [{{name: q, plugin: rigid}}]\n"
        );
        let _ = jointctl_config::parse_str(&yaml, "fuzz.yaml");
        let _ = jointctl_config::parse_str(&format!("{yaml}{garbage}"), "fuzz.yaml");
        if let Ok(l) = jointctl_config::parse_str(&yaml, "fuzz.yaml") {
            for bus in &l.config.buses.can {
                // A config that parses gives a finite budget.
                let drives = bus.drives.len();
                prop_assert!(drives <= 1);
            }
        }
    }
}
