use jointctl_control::InvalidNumber;
use serde::Deserialize;

/// The shape of a reference signal (thesis chapter 5: step, sine and cosine torque references).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Waveform {
    /// `offset` before `start_s`, `offset + amplitude` from then on.
    Step,
    /// `offset + amplitude * sin(2 pi f (t - start))` from `start_s`, `offset` before.
    Sine,
    /// `offset + amplitude * cos(2 pi f (t - start))` from `start_s`, `offset` before.
    Cosine,
}

/// A reference generator: evaluated every cycle, allocation-free.
///
/// ```
/// use jointctl_modes::{Reference, Waveform};
/// let r = Reference { waveform: Waveform::Sine, amplitude: 5.0, frequency_hz: 0.1, offset: 1.0, start_s: 2.0 };
/// assert_eq!(r.value(0.0), 1.0);
/// assert!((r.value(4.5) - (1.0 + 5.0)).abs() < 1e-9); // a quarter period after the start
/// let s = Reference { waveform: Waveform::Step, amplitude: 20.0, frequency_hz: 0.0, offset: 0.0, start_s: 1.0 };
/// assert_eq!((s.value(0.5), s.value(1.0)), (0.0, 20.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Reference {
    /// The shape.
    pub waveform: Waveform,
    /// Amplitude, in the unit of the signal (Nm for torque references).
    pub amplitude: f64,
    /// Frequency [Hz] (sine, cosine).
    #[serde(default)]
    pub frequency_hz: f64,
    /// Offset, in the unit of the signal.
    #[serde(default)]
    pub offset: f64,
    /// Start time [s], on the clock the runtime passes in.
    #[serde(default)]
    pub start_s: f64,
}

impl Reference {
    /// The value at time `t_s`.
    pub fn value(&self, t_s: f64) -> f64 {
        let tau = t_s - self.start_s;
        if tau < 0.0 {
            return self.offset;
        }
        let phase = 2.0 * std::f64::consts::PI * self.frequency_hz * tau;
        self.offset
            + self.amplitude
                * match self.waveform {
                    Waveform::Step => 1.0,
                    Waveform::Sine => phase.sin(),
                    Waveform::Cosine => phase.cos(),
                }
    }

    /// Checks the numbers are finite and the frequency non-negative.
    pub fn validate(&self) -> Result<(), InvalidNumber> {
        for (name, v) in [("amplitude", self.amplitude), ("frequency_hz", self.frequency_hz), ("offset", self.offset), ("start_s", self.start_s)] {
            InvalidNumber::check(name, v, "finite", v.is_finite())?;
        }
        InvalidNumber::check("frequency_hz", self.frequency_hz, ">= 0", self.frequency_hz >= 0.0)?;
        Ok(())
    }

    /// The largest absolute value the signal reaches.
    pub fn peak(&self) -> f64 {
        self.offset.abs().max((self.offset + self.amplitude).abs()).max((self.offset - self.amplitude).abs())
    }
}
