//! What an inspector does: read a running arm's joint states from iceoryx2 shared memory.
//!
//! `cargo run --example read_shared_memory`
//!
//! So that the example needs nothing else running, it starts a one-joint simulated arm in a
//! thread (what `jointctl run` does in its own process); the reader below does not care where the
//! arm runs, only what it is called (`arm:` in its YAML).

use std::time::{Duration, Instant};

use jointctl_ipc::{FieldMask, ServiceNames, decode_name};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arm_name = format!("example-reader-{}", std::process::id());
    let stop = jointctl_runtime::signals::StopRequest::manual();
    let runtime = start_arm(&arm_name, stop.clone())?;

    // The reader: a node in the default iceoryx2 domain, a subscriber to `<arm>/joint_state`.
    let node = jointctl_ipc::create_node(None, "example-reader")?;
    let names = ServiceNames::for_arm(&arm_name);
    let subscriber = jointctl_ipc::joint_state_service(&node, &names.joint_state)?.subscriber_builder().create()?;
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut printed = 0;
    while printed < 5 {
        if runtime.is_finished() {
            // The arm's loop ended early: its error says why.
            return Err(runtime.join().map_err(|_| "the arm's thread panicked")?.err().unwrap_or_else(|| "the arm stopped before 5 samples were read".into()).into());
        }
        if Instant::now() > deadline {
            stop.request();
            return Err("no joint state within 5 s".into());
        }
        // The newest sample: a reader that looks every 20 ms skips what came in between.
        let mut newest = None;
        while let Some(sample) = subscriber.receive()? {
            newest = Some(sample);
        }
        let Some(sample) = newest else {
            std::thread::sleep(Duration::from_millis(1));
            continue;
        };
        // The payload is a slice with one entry per DOF, the header the cycle's; a field whose
        // bit is not set in `valid_mask` is unknown this cycle (its value is NaN), never zero.
        for joint in sample.payload() {
            let position = joint.get(FieldMask::POSITION, joint.position_rad);
            println!("cycle {:>5}  {}  position {}", sample.user_header().cycle, decode_name(&joint.name), position.map_or("unknown".into(), |q| format!("{q:+.4} rad")));
        }
        printed += 1;
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(subscriber);
    // Stop the arm as `jointctl cmd stop` or Ctrl-C would: it holds its joint, publishes a final
    // sample and releases the shared memory.
    stop.request();
    runtime.join().map_err(|_| "the arm's thread panicked")??;
    Ok(())
}

/// A one-joint simulated arm at 200 Hz, publishing to shared memory, its joint moving to 0.2 rad,
/// until `stop` is requested (at most 60 s): the loop `jointctl run` runs, on a thread.
fn start_arm(arm_name: &str, stop: jointctl_runtime::signals::StopRequest) -> Result<std::thread::JoinHandle<Result<(), String>>, Box<dyn std::error::Error>> {
    let yaml = jointctl_examples::one_joint_arm(arm_name, "rigid", 200.0, "{stiffness_nm_per_rad: 8.3e4, position_pi: {kp: 0.2, ki: 0.5, output_limit: 0.05}}");
    let loaded = jointctl_config::parse_str(&yaml, "reader.yaml")?;
    let mut loader = jointctl_runtime::PluginLoader::new([]);
    loader.register_static(jointctl_plugin_rigid::plugin_descriptor())?;
    let mut arm = jointctl_backends::build_arm(&loaded, &loader)?;
    arm.activate()?;
    arm.set_mode(0, jointctl_modes::Mode::Position { target_rad: 0.2 });
    let mut publisher = jointctl_runtime::ArmPublisher::new(&arm, None)?;
    Ok(std::thread::spawn(move || {
        let opts = jointctl_runtime::RunOptions { cycles: Some(12_000), stop: Some(stop), ..Default::default() };
        jointctl_runtime::run(&mut arm, &loaded.config.timing, Some(&mut publisher), &opts).map(|_| ()).map_err(|e| e.to_string())
    }))
}
