//! The One Euro filter (Casiez, Roussel & Vogel, CHI 2012): a low-pass filter whose
//! cut-off rises with speed, so a still joint stops jittering and a moving one does not
//! lag. The pose stage smooths joints with it, the gesture stage the drawing hand
//! ([`OneEuroPlane`]: one cut-off for both coordinates).

/// One Euro filter for one coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct OneEuro {
    /// Cut-off (Hz) at rest: lower is smoother.
    pub min_cutoff: f64,
    /// How fast the cut-off rises with speed (per unit of speed): higher lags less.
    pub beta: f64,
    /// Cut-off (Hz) of the speed estimate.
    pub d_cutoff: f64,
    x: Option<f64>,
    dx: f64,
    t: f64,
}

fn alpha(cutoff: f64, dt: f64) -> f64 {
    let tau = 1.0 / (2.0 * std::f64::consts::PI * cutoff);
    1.0 / (1.0 + tau / dt)
}

impl OneEuro {
    pub fn new(min_cutoff: f64, beta: f64, d_cutoff: f64) -> Self {
        Self {
            min_cutoff,
            beta,
            d_cutoff,
            x: None,
            dx: 0.0,
            t: 0.0,
        }
    }

    /// Filters `x` observed at time `t` seconds (times must not decrease; equal times
    /// count as a tenth of a millisecond apart).
    pub fn filter(&mut self, x: f64, t: f64) -> f64 {
        let Some(prev) = self.x else {
            self.x = Some(x);
            self.t = t;
            return x;
        };
        let dt = (t - self.t).max(1e-4);
        self.t = t;
        let dx = (x - prev) / dt;
        self.dx += alpha(self.d_cutoff, dt) * (dx - self.dx);
        let cutoff = self.min_cutoff + self.beta * self.dx.abs();
        let v = prev + alpha(cutoff, dt) * (x - prev);
        self.x = Some(v);
        v
    }

    /// Forgets the signal: the next value passes unchanged.
    pub fn reset(&mut self) {
        self.x = None;
        self.dx = 0.0;
    }
}

/// One Euro filter for a point in the plane: both
/// coordinates share one cut-off, raised by the point's speed (the length of its
/// smoothed velocity), so a moving hand is followed alike in every direction. Two
/// [`OneEuro`]s, one a coordinate, smooth each coordinate hardest where it turns, at
/// another moment than the other: a circle comes out an ellipse.
#[derive(Debug, Clone, PartialEq)]
pub struct OneEuroPlane {
    pub min_cutoff: f64,
    pub beta: f64,
    pub d_cutoff: f64,
    x: Option<[f64; 2]>,
    dx: [f64; 2],
    t: f64,
}

impl OneEuroPlane {
    pub fn new(min_cutoff: f64, beta: f64, d_cutoff: f64) -> Self {
        Self {
            min_cutoff,
            beta,
            d_cutoff,
            x: None,
            dx: [0.0; 2],
            t: 0.0,
        }
    }

    /// Filters point `p` observed at time `t` seconds (as [`OneEuro::filter`]).
    pub fn filter(&mut self, p: [f64; 2], t: f64) -> [f64; 2] {
        let Some(prev) = self.x else {
            self.x = Some(p);
            self.t = t;
            return p;
        };
        let dt = (t - self.t).max(1e-4);
        self.t = t;
        let a = alpha(self.d_cutoff, dt);
        for k in 0..2 {
            self.dx[k] += a * ((p[k] - prev[k]) / dt - self.dx[k]);
        }
        let speed = self.dx[0].hypot(self.dx[1]);
        let a = alpha(self.min_cutoff + self.beta * speed, dt);
        let v = [
            prev[0] + a * (p[0] - prev[0]),
            prev[1] + a * (p[1] - prev[1]),
        ];
        self.x = Some(v);
        v
    }

    /// Forgets the signal: the next point passes unchanged.
    pub fn reset(&mut self) {
        self.x = None;
        self.dx = [0.0; 2];
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
