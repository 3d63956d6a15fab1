//! The out-of-tree example plugin (plugins/example_sea, its own workspace) loads from the path
//! in configs/example_sea_rig.yaml alone.

#[test]
fn the_example_sea_plugin_loads_from_yaml_alone_and_prefers_its_torque_sensor() {
    let cfg = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/example_sea_rig.yaml");
    let so = cfg.parent().unwrap().join("../plugins/example_sea/target/debug/libexample_sea.so");
    assert!(so.exists(), "build the example first: cargo build --manifest-path plugins/example_sea/Cargo.toml (the README's test command does)");
    let loaded = jointctl_config::load(&cfg).unwrap();
    // No search path at all: only the YAML's `path` can find it.
    let loader = jointctl_runtime::PluginLoader::new([]);
    let mut arm = jointctl_backends::build_arm(&loaded, &loader).unwrap();
    arm.activate().unwrap();
    arm.step(0.01);
    assert_eq!(arm.slots[0].plugin, "example_sea");
    // The simulated torque sensor reads 1.5 Nm (through the 14-bit SPI codec, so within one
    // count); the spring model would say 0.
    assert!((arm.states[0].torque().unwrap() - 1.5).abs() < std::f64::consts::TAU / 16384.0);
    assert_eq!(arm.states[0].stiffness(), Some(250.0));
}
