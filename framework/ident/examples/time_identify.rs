use std::time::Instant;
fn main() {
    let n: usize = std::env::args().nth(1).map_or(100_000, |s| s.parse().unwrap());
    let (amp, f, k, fc, lambda) = (0.1, 0.2371, 120.0, 1.0, 0.005);
    let q = std::f64::consts::TAU / 16384.0;
    let mut z: f64 = 0.0;
    let mut prev = 0.0;
    let mut rng = jointctl_test_support::XorShift64::new(0x1234_5678_9abc_def1);
    let mut noise = || (rng.uniform() - 0.5) * 0.05;
    let mut data = jointctl_ident::csv::Data::default();
    for i in 0..n {
        let t = i as f64 / 200.0;
        let x = amp * (std::f64::consts::TAU * f * t).sin();
        let step = x - prev;
        if step != 0.0 { let s = step.signum(); z = s + (z - s) * (-step.abs() / lambda).exp(); }
        prev = x;
        data.t.push(t);
        data.deflection.push((x / q).round() * q);
        data.torque.push(k * x + 0.3 * (80.0 * amp * std::f64::consts::TAU * f * (std::f64::consts::TAU * f * t).cos()).atan() + fc * z + noise());
        for v in [&mut data.pivot_mm, &mut data.angle_deg, &mut data.motor_position, &mut data.reference_torque] { v.push(f64::NAN); }
    }
    let t = Instant::now();
    let _ = jointctl_ident::fit::fit(&data, &Default::default()).unwrap();
    let fit_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let r = jointctl_ident::identify::identify(&data, &Default::default()).unwrap();
    println!("fit {fit_s:.4} s identify {:.3} s causes {:?}", t.elapsed().as_secs_f64(), r.causes.iter().map(|c| &c.effect).collect::<Vec<_>>());
}
