//! # jointctl-test-support
//!
//! What tests and benchmarks share and the product does not need. Kept dependency-free so that
//! any crate's dev-dependencies can use it without a cycle (the workspace test crate depends on
//! every framework crate; this one on none).

mod counting_alloc;
pub mod generated_arm;
pub mod hidden_effects;

pub use counting_alloc::{CountingAlloc, count_allocations};

/// Marsaglia's xorshift64 (shifts 13, 7, 17): fast, seeded, reproducible across platforms.
/// Not for cryptography; for synthetic noise and fault patterns in tests.
///
/// ```
/// use jointctl_test_support::XorShift64;
/// let mut a = XorShift64::new(42);
/// let mut b = XorShift64::new(42);
/// assert_eq!(a.next_u64(), b.next_u64());
/// let u = a.uniform();
/// assert!((0.0..1.0).contains(&u));
/// ```
#[derive(Clone, Debug)]
pub struct XorShift64(u64);

impl XorShift64 {
    /// A generator from a seed; a zero seed (the one fixed point) is replaced by a constant.
    pub fn new(seed: u64) -> Self {
        XorShift64(if seed == 0 { 0x2545_f491_4f6c_dd1d } else { seed })
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in [0, 1), 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [a, b).
    ///
    /// ```
    /// let x = jointctl_test_support::XorShift64::new(7).range(-2.0, 3.0);
    /// assert!((-2.0..3.0).contains(&x));
    /// ```
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }

    /// Standard normal (Box-Muller, cosine branch; two uniforms per draw).
    ///
    /// ```
    /// let mut g = jointctl_test_support::XorShift64::new(1);
    /// let n = 20_000;
    /// let (s, s2) = (0..n).map(|_| g.normal()).fold((0.0, 0.0), |(s, s2), x| (s + x, s2 + x * x));
    /// let (mean, var) = (s / n as f64, s2 / n as f64 - (s / n as f64).powi(2));
    /// assert!(mean.abs() < 0.03 && (var - 1.0).abs() < 0.05, "{mean} {var}");
    /// ```
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-12), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}
