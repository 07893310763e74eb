//! The One Euro filter (Casiez, Roussel & Vogel, CHI 2012): a low-pass filter whose
//! cut-off rises with speed, so a still joint stops jittering and a moving one does not
//! lag. The pose stage smooths joints with it, the gesture stage the drawing hand
//! ([`OneEuroPlane`]: one cut-off for both coordinates, [`OneEuroPoint`]).

/// One Euro filter for a point of `N` coordinates that share one cut-off, raised by the
/// point's speed (the length of its smoothed velocity), so a moving point is followed
/// alike in every direction. `N` filters of one coordinate each would smooth each
/// coordinate hardest where it turns, at another moment than the others: a circle drawn
/// by the hand comes out an ellipse.
#[derive(Debug, Clone, PartialEq)]
pub struct OneEuroPoint<const N: usize> {
    /// Cut-off (Hz) at rest: lower is smoother.
    pub min_cutoff: f64,
    /// How fast the cut-off rises with speed (per unit of speed): higher lags less.
    pub beta: f64,
    /// Cut-off (Hz) of the speed estimate.
    pub d_cutoff: f64,
    x: Option<[f64; N]>,
    dx: [f64; N],
    t: f64,
}

/// The hand's filter in the plane (the gesture stage).
pub type OneEuroPlane = OneEuroPoint<2>;

fn alpha(cutoff: f64, dt: f64) -> f64 {
    let tau = 1.0 / (2.0 * std::f64::consts::PI * cutoff);
    1.0 / (1.0 + tau / dt)
}

impl<const N: usize> OneEuroPoint<N> {
    /// A filter with the One Euro parameters: the cut-off at rest (Hz), how fast it rises
    /// with speed, and the cut-off of the speed's own filter (Hz).
    pub fn new(min_cutoff: f64, beta: f64, d_cutoff: f64) -> Self {
        Self {
            min_cutoff,
            beta,
            d_cutoff,
            x: None,
            dx: [0.0; N],
            t: 0.0,
        }
    }

    /// Filters point `p` observed at time `t` seconds (times must not decrease; equal
    /// times count as a tenth of a millisecond apart).
    pub fn filter(&mut self, p: [f64; N], t: f64) -> [f64; N] {
        let Some(prev) = self.x else {
            self.x = Some(p);
            self.t = t;
            return p;
        };
        let dt = (t - self.t).max(1e-4);
        self.t = t;
        let a = alpha(self.d_cutoff, dt);
        for k in 0..N {
            self.dx[k] += a * ((p[k] - prev[k]) / dt - self.dx[k]);
        }
        // hypot from 0 is the absolute value: one coordinate is filtered exactly as
        // the paper's scalar filter.
        let speed = self.dx.iter().fold(0.0f64, |s, d| s.hypot(*d));
        let a = alpha(self.min_cutoff + self.beta * speed, dt);
        let v = std::array::from_fn(|k| prev[k] + a * (p[k] - prev[k]));
        self.x = Some(v);
        v
    }

    /// Forgets the signal: the next point passes unchanged.
    pub fn reset(&mut self) {
        self.x = None;
        self.dx = [0.0; N];
    }
}

/// One Euro filter for one coordinate (the pose stage's joints, each coordinate apart).
#[derive(Debug, Clone, PartialEq)]
pub struct OneEuro(OneEuroPoint<1>);

impl OneEuro {
    /// A filter with the One Euro parameters (see [`OneEuroPoint::new`]).
    pub fn new(min_cutoff: f64, beta: f64, d_cutoff: f64) -> Self {
        Self(OneEuroPoint::new(min_cutoff, beta, d_cutoff))
    }

    /// Filters `x` observed at time `t` seconds (as [`OneEuroPoint::filter`]).
    pub fn filter(&mut self, x: f64, t: f64) -> f64 {
        self.0.filter([x], t)[0]
    }

    /// Forgets the signal: the next value passes unchanged.
    pub fn reset(&mut self) {
        self.0.reset();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_still_noisy_signal_is_smoothed_and_a_step_is_followed() {
        let mut f = OneEuro::new(1.0, 0.5, 1.0);
        // ±1 cm alternating noise around 2 m at 30 Hz.
        let mut dev: f64 = 0.0;
        for i in 0..90 {
            let x = 2.0 + if i % 2 == 0 { 0.01 } else { -0.01 };
            let y = f.filter(x, i as f64 / 30.0);
            if i > 30 {
                dev = dev.max((y - 2.0).abs());
            }
        }
        assert!(dev < 0.004, "residual jitter {dev}");
        // A fast move of 0.5 m is followed within a few frames.
        let mut y = 0.0;
        for i in 90..96 {
            y = f.filter(2.5, i as f64 / 30.0);
        }
        assert!((y - 2.5).abs() < 0.05, "lags at {y}");
        f.reset();
        assert_eq!(f.filter(7.0, 10.0), 7.0);
    }
}
