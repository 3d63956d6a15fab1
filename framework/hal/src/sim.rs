//! The simulated backend: each drive is a perfect position drive with a first-order response
//! and each encoder follows a drive through a gain, or reads a fixed angle (an output clamped as
//! in the thesis' characterisation and validation set-ups, figures 3.13, 5.1). Seeded, and stepped
//! by the runtime, so a run is repeatable and can go faster than real time.

use jointctl_api::{DriveAction, DriveReading, Reading};
use jointctl_config::{ArmConfig, CanLossMode, EncoderSimConfig};

use crate::codec::{as5048, canopen};
use crate::condition::{Conditioner, Plausibility, Sample};
use crate::{ActuatorFrame, DeviceHealth, DeviceIndex, Hal, HalIoError, HalSetupError, SensorFrame};

#[derive(Clone, Debug)]
enum EncoderModel {
    /// `offset + sum(gain_i * drive_i)`.
    Follows { terms: Vec<(usize, f64)>, offset_rad: f64 },
    Fixed(f64),
}

/// The simulated arm.
///
/// ```
/// use jointctl_hal::{ActuatorFrame, DeviceIndex, Hal, SensorFrame, sim::SimHal};
/// let cfg = jointctl_config::parse_str(r#"
/// arm: a
/// hal: {backend: sim}
/// buses:
///   can: [{interface: can0, drives: [{name: m, node_id: 1}]}]
///   spi: [{device: /dev/spidev0, encoders: [{name: e, chip_select: 0, sim: {drive: m, gain: 2.0}}]}]
/// joints: [{name: q, plugin: rigid}]
/// "#, "a.yaml").unwrap().config;
/// let devices = DeviceIndex::of(&cfg);
/// let mut hal = SimHal::new(&cfg).unwrap();
/// let mut out = ActuatorFrame::new(&devices);
/// out.drives[0] = jointctl_api::MotorSetpoint::move_to(1.0);
/// for _ in 0..1000 { hal.write(&out, 0.01).unwrap(); }
/// let mut frame = SensorFrame::new(&devices);
/// hal.read(&mut frame).unwrap();
/// // Quantised to 14 bits, as on the robot (2 pi / 16384 = 0.38 mrad).
/// assert!((frame.encoders[0].value - 2.0).abs() < 4e-4);
/// ```
#[derive(Clone, Debug)]
pub struct SimHal {
    drive_position_rad: Vec<f64>,
    drive_velocity_rad_s: Vec<f64>,
    drive_target_rad: Vec<f64>,
    encoders: Vec<EncoderModel>,
    encoder_offset_rad: Vec<f64>,
    noise_rad: f64,
    tau_s: f64,
    rng: SplitMix64,
    quantize: bool,
    loss_rate: f64,
    loss_mode: CanLossMode,
    counts_per_rad: Vec<f64>,
    encoder_conditioners: Vec<Conditioner>,
    drive_conditioners: Vec<Conditioner>,
    time_s: f64,
}

impl SimHal {
    /// A simulated arm for a configuration. Every encoder needs a `sim` section.
    pub fn new(config: &ArmConfig) -> Result<Self, HalSetupError> {
        let devices = DeviceIndex::of(config);
        let mut encoders = Vec::new();
        let mut offsets = Vec::new();
        for (b, bus) in config.buses.spi.iter().enumerate() {
            for (i, e) in bus.encoders.iter().enumerate() {
                let field = format!("buses.spi[{b}].encoders[{i}].sim");
                let lookup = |d: &str, f: String| {
                    devices.drive(d).ok_or_else(|| HalSetupError::Config { field: f, message: format!("no drive named `{d}`") })
                };
                let model = match &e.sim {
                    Some(EncoderSimConfig { fixed_rad: Some(q), .. }) => EncoderModel::Fixed(*q),
                    Some(EncoderSimConfig { drive: Some(d), gain, offset_rad, .. }) => EncoderModel::Follows {
                        terms: vec![(lookup(d, format!("{field}.drive"))?, *gain)],
                        offset_rad: *offset_rad,
                    },
                    Some(EncoderSimConfig { sum, offset_rad, .. }) if !sum.is_empty() => EncoderModel::Follows {
                        terms: sum
                            .iter()
                            .enumerate()
                            .map(|(t, term)| Ok((lookup(&term.drive, format!("{field}.sum[{t}].drive"))?, term.gain)))
                            .collect::<Result<_, HalSetupError>>()?,
                        offset_rad: *offset_rad,
                    },
                    _ => {
                        return Err(HalSetupError::Config {
                            field,
                            message: format!(
                                "the simulated backend needs to know what encoder `{}` reads: add `sim: {{drive: NAME, gain: G}}`, `sim: {{sum: [{{drive: NAME, gain: G}}, ...]}}` or `sim: {{fixed_rad: Q}}`",
                                e.name
                            ),
                        });
                    }
                };
                encoders.push(model);
                offsets.push(e.offset_rad);
            }
        }
        let n = devices.drives.len();
        let drives: Vec<_> = config.buses.can.iter().flat_map(|b| b.drives.iter()).collect();
        let encoder_rates: Vec<f64> = config.buses.spi.iter().flat_map(|b| b.encoders.iter().map(|e| e.max_velocity_rad_s)).collect();
        Ok(SimHal {
            quantize: config.hal.sim.quantize_encoders,
            loss_rate: config.hal.sim.can_loss_rate,
            loss_mode: config.hal.sim.can_loss_mode,
            counts_per_rad: drives.iter().map(|d| d.counts_per_rad).collect(),
            drive_conditioners: drives.iter().map(|d| Conditioner::new(Plausibility::drive_position(d.max_velocity_rad_s))).collect(),
            encoder_conditioners: encoder_rates.iter().map(|r| Conditioner::new(Plausibility::absolute_encoder(*r))).collect(),
            time_s: 0.0,
            drive_position_rad: vec![0.0; n],
            drive_velocity_rad_s: vec![0.0; n],
            drive_target_rad: vec![0.0; n],
            encoders,
            encoder_offset_rad: offsets,
            noise_rad: config.hal.sim.encoder_noise_rad,
            tau_s: config.hal.sim.drive_time_constant_s,
            rng: SplitMix64(config.hal.sim.seed ^ 0x9e37_79b9_7f4a_7c15),
        })
    }
}

impl Hal for SimHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        for (i, model) in self.encoders.iter().enumerate() {
            let truth = match model {
                EncoderModel::Follows { terms, offset_rad } => {
                    offset_rad + terms.iter().map(|(d, g)| g * self.drive_position_rad[*d]).sum::<f64>()
                }
                EncoderModel::Fixed(q) => *q,
            };
            let noise = if self.noise_rad > 0.0 { self.noise_rad * self.rng.normal() } else { 0.0 };
            let angle = truth + noise - self.encoder_offset_rad[i];
            // The same frames and decoder as the robot's SPI bus: 14-bit words with parity.
            let sample = if self.quantize {
                match as5048::decode(as5048::encode(as5048::rad_to_counts(angle))) {
                    Ok(counts) => Sample::Value { value: as5048::counts_to_rad(counts), age_s: 0.0 },
                    Err(_) => Sample::Invalid,
                }
            } else {
                Sample::Value { value: angle, age_s: 0.0 }
            };
            frame.encoders[i] = if self.quantize {
                self.encoder_conditioners[i].update(sample, self.time_s)
            } else {
                match sample {
                    Sample::Value { value, .. } => Reading::valid(value),
                    _ => Reading::invalid(),
                }
            };
        }
        for (i, d) in frame.drives.iter_mut().enumerate() {
            // The same TPDO1 frames and decoder as the robot's CAN bus, with losses.
            let counts = (self.drive_position_rad[i] * self.counts_per_rad[i]).round() as i32;
            let lost = self.loss_rate > 0.0 && self.rng.uniform() < self.loss_rate;
            let frame_out = match (lost, self.loss_mode) {
                (false, _) => Some(canopen::tpdo1(i as u8 + 1, 0x0237, counts)),
                (true, CanLossMode::Zero) => Some(canopen::tpdo1(i as u8 + 1, 0x0237, 0)),
                (true, CanLossMode::Missing) => None,
            };
            let sample = match frame_out.as_ref().and_then(canopen::decode_tpdo1) {
                Some(t) => Sample::Value { value: t.position_counts as f64 / self.counts_per_rad[i], age_s: 0.0 },
                None => Sample::Missing,
            };
            let position = self.drive_conditioners[i].update(sample, self.time_s);
            *d = DriveReading::new(position, Reading::valid(self.drive_velocity_rad_s[i]), true, false);
        }
        Ok(())
    }

    fn device_health(&self, out: &mut [DeviceHealth]) {
        let all = self.drive_conditioners.iter().chain(&self.encoder_conditioners);
        for (h, c) in out.iter_mut().zip(all) {
            let l = c.counters();
            *h = DeviceHealth { missing: l.missing, invalid: l.invalid, implausible: l.implausible, emcy: 0, flags: 0 };
        }
    }

    fn write(&mut self, frame: &ActuatorFrame, dt_s: f64) -> Result<(), HalIoError> {
        self.time_s += dt_s;
        let alpha = 1.0 - (-dt_s / self.tau_s).exp();
        for (i, sp) in frame.drives.iter().enumerate() {
            if sp.action == DriveAction::MOVE && sp.position_rad.is_finite() {
                self.drive_target_rad[i] = sp.position_rad;
            }
            let before = self.drive_position_rad[i];
            self.drive_position_rad[i] += alpha * (self.drive_target_rad[i] - before);
            self.drive_velocity_rad_s[i] = if dt_s > 0.0 { (self.drive_position_rad[i] - before) / dt_s } else { 0.0 };
        }
        Ok(())
    }
}

/// SplitMix64 with a Box-Muller normal: enough for seeded sensor noise, and allocation-free.
#[derive(Clone, Debug)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}
