//! [`SimHal`] as a HAL backend: the encoders, drives and force/torque sensors read through the
//! robot's codecs, latencies and conditioners, and set-points written over the CAN bus.

use jointctl_api::{DriveAction, DriveReading, Reading};
use jointctl_config::CanLossMode;
use jointctl_hal::codec::{as5048, canopen};
use jointctl_hal::condition::Sample;
use jointctl_hal::{ActuatorFrame, DeviceHealth, Hal, HalIoError, SensorFrame};

use super::{EncoderFault, SimHal};

impl Hal for SimHal {
    fn read(&mut self, frame: &mut SensorFrame) -> Result<(), HalIoError> {
        let now = self.time_s;
        for i in 0..self.encoders.len() {
            let truth = self.encoder_history[i].at(now - self.spi_latency_s);
            let noise = if self.noise_rad > 0.0 { self.noise_rad * self.rng.normal() } else { 0.0 };
            let angle = truth + noise - self.encoder_offset_rad[i];
            frame.encoders[i] = if let Some(fault) = self.encoder_faults[i] {
                let sample = match fault {
                    EncoderFault::Silent => Sample::Missing,
                    EncoderFault::Corrupt => Sample::Invalid,
                    EncoderFault::Offset(jump) => Sample::Value { value: angle + jump, age_s: self.spi_latency_s },
                };
                self.encoder_conditioners[i].update(sample, now)
            } else if self.quantized[i] {
                // The same frames and decoder as the robot's SPI bus: 14-bit words with parity.
                let sample = match as5048::decode(as5048::encode(as5048::rad_to_counts(angle))) {
                    Ok(counts) => Sample::Value { value: as5048::counts_to_rad(counts), age_s: self.spi_latency_s },
                    Err(_) => Sample::Invalid,
                };
                self.encoder_conditioners[i].update(sample, now)
            } else {
                Reading::valid_aged(angle, self.spi_latency_s)
            };
        }
        for (i, d) in frame.drives.iter_mut().enumerate() {
            // The same TPDO1 frames and decoder as the robot's CAN bus, with latency and losses;
            // with the torque actual value (per mille of the rated torque) when it is read.
            let read_at = now - self.can_feedback_latency_s;
            let position = self.drive_history[i].at(read_at);
            let counts = (position * self.counts_per_rad[i]).round() as i32;
            let rated = self.rated_torque_nm[i];
            let tpdo1 = |statusword: u16, counts: i32, torque_nm: f64| match rated {
                Some(r) => canopen::tpdo1_with_torque(self.node_ids[i], statusword, counts, (torque_nm / r * 1000.0).round().clamp(-32767.0, 32767.0) as i16),
                None => canopen::tpdo1(self.node_ids[i], statusword, counts),
            };
            let lost = self.loss_rate > 0.0 && self.rng.uniform() < self.loss_rate;
            let frame_out = match (lost, self.loss_mode) {
                (false, _) => Some(tpdo1(0x0237, counts, self.drive_torque_history[i].at(read_at))),
                // Appendix A: the whole frame reads zero.
                (true, CanLossMode::Zero) => Some(tpdo1(0, 0, 0.0)),
                (true, CanLossMode::Missing) => None,
            };
            let decoded = frame_out.as_ref().and_then(canopen::decode_tpdo1);
            let sample = match decoded {
                Some(t) => Sample::Value { value: t.position_counts as f64 / self.counts_per_rad[i], age_s: self.can_feedback_latency_s },
                None => Sample::Missing,
            };
            let reading = self.drive_conditioners[i].update(sample, now);
            // As the robot's HAL: valid from this cycle's frame when its position was accepted and
            // it is not a zeroed frame (statusword 0: its torque is not one even where its zero
            // position passes, a drive resting at zero), stale from the last
            // accepted one, invalid with an invalid position.
            let in_frame = decoded.and_then(|t| t.torque_nm(rated));
            let torque = match (in_frame, self.drive_torque_last[i]) {
                _ if rated.is_none() => Reading::MISSING,
                _ if reading.status == jointctl_api::ReadingStatus::INVALID => Reading::invalid(),
                (Some(nm), _) if reading.status == jointctl_api::ReadingStatus::VALID => {
                    self.drive_torque_last[i] = Some((nm, read_at));
                    Reading::valid_aged(nm, now - read_at)
                }
                (_, Some((nm, at))) => Reading::stale(nm, now - at),
                (_, None) => Reading::MISSING,
            };
            *d = DriveReading::new(reading, Reading::valid(self.drives[i].velocity), true, false).with_torque(torque);
        }
        // Force/torque sensors: the simulated sensor's torque (effects and noise included), read
        // as it is now (a Net F/T box streams at kHz rates: no bus latency modelled), beyond its
        // range invalid.
        for (out, ((unit, dof), range, conditioner)) in frame.torque_sensors.iter_mut().zip(&mut self.torque_sensors) {
            let tau = self.units[*unit].sensor_torque[*dof];
            let sample = if tau.abs() <= *range { Sample::Value { value: tau, age_s: 0.0 } } else { Sample::Invalid };
            *out = conditioner.update(sample, now);
        }
        Ok(())
    }

    fn write(&mut self, frame: &ActuatorFrame, dt_s: f64) -> Result<(), HalIoError> {
        // Set-points cross the CAN bus as readings do: they reach the drive `can_latency_s` later.
        let due = self.time_s + self.can_latency_s;
        for (wire, sp) in self.in_flight.iter_mut().zip(&frame.drives) {
            if sp.action == DriveAction::MOVE && sp.position_rad.is_finite() {
                wire.push(due, sp.position_rad);
            }
        }
        self.advance(dt_s);
        Ok(())
    }

    fn device_health(&self, out: &mut [DeviceHealth]) {
        let all = self.drive_conditioners.iter().chain(&self.encoder_conditioners).chain(self.torque_sensors.iter().map(|t| &t.2));
        for (h, c) in out.iter_mut().zip(all) {
            let l = c.counters();
            *h = DeviceHealth { missing: l.missing, invalid: l.invalid, implausible: l.implausible, emcy: 0, flags: 0 };
        }
    }
}
