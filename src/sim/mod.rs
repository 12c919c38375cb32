//! Simulation: the embedded virtual FTS, user plants, reference trajectories
//! and closed-loop runs through the runtime controller step.

pub mod closed_loop;
pub mod contour;
pub mod disturbance;
pub mod experiment;
pub mod path;
pub mod reference;
pub mod scurve;
pub mod virtual_fts;

/// A sampled plant as the controller sees it: read the sensor, then apply a
/// command for one sample period.
pub trait Plant {
    /// Sample time, s.
    fn ts(&self) -> f64;
    /// A sensor reading now.
    fn measure(&mut self) -> f64;
    /// Applies `command` for one sample period.
    fn advance(&mut self, command: f64);
    /// The noise-free output now (for plots; equals the reading for a noise-free plant).
    fn true_output(&self) -> f64;
}

impl Plant for virtual_fts::VirtualFts {
    fn ts(&self) -> f64 {
        self.params().ts
    }
    fn measure(&mut self) -> f64 {
        virtual_fts::VirtualFts::measure(self)
    }
    fn advance(&mut self, command: f64) {
        virtual_fts::VirtualFts::advance(self, command)
    }
    fn true_output(&self) -> f64 {
        self.true_position()
    }
}

/// A user's plant: an optional forward hysteresis model (command -> its
/// output) followed by a discrete transfer function, with optional white
/// measurement noise. The command is clipped to `command_limits`.
#[derive(Debug, Clone)]
pub struct ModelPlant {
    hysteresis: Option<(
        crate::ident::hysteresis::HysteresisModel,
        crate::ident::hysteresis::ModelState,
    )>,
    linear: crate::lti::TdfFilter,
    ts: f64,
    output: f64,
    command_limits: (f64, f64),
    noise: Option<(rand_chacha::ChaCha8Rng, rand_distr::Normal<f64>)>,
}

impl ModelPlant {
    /// A plant at rest. `noise_rms` 0 means noise-free. The linear part
    /// must have a delay of at least one sample: the controller reads `y(k)`
    /// before it computes `u(k)`, so `y(k)` cannot depend on `u(k)`. The
    /// filter runs with delay `d - 1` and its output after `u(k)` is `y(k+1)`,
    /// which realises `z^-d B/A` exactly.
    pub fn new(
        linear: &crate::lti::DiscreteTf,
        hysteresis: Option<crate::ident::hysteresis::HysteresisModel>,
        command_limits: (f64, f64),
        noise_rms: f64,
        seed: u64,
    ) -> Result<Self, String> {
        use rand::SeedableRng;
        if linear.delay() == 0 {
            return Err("the plant model needs a delay of at least one sample (\"delay\" >= 1): the measurement is taken before the command is applied".into());
        }
        let noise = (noise_rms > 0.0)
            .then(|| rand_distr::Normal::new(0.0, noise_rms).ok())
            .flatten()
            .map(|n| (rand_chacha::ChaCha8Rng::seed_from_u64(seed), n));
        let shifted = crate::lti::TdfFilter::from_coeffs(
            linear.num().coeffs(),
            linear.den().coeffs(),
            linear.delay() - 1,
        );
        Ok(Self {
            hysteresis: hysteresis.map(|m| {
                let s = m.new_state();
                (m, s)
            }),
            linear: shifted,
            ts: linear.ts(),
            output: 0.0,
            command_limits,
            noise,
        })
    }
}

impl Plant for ModelPlant {
    fn ts(&self) -> f64 {
        self.ts
    }
    fn measure(&mut self) -> f64 {
        use rand_distr::Distribution;
        match &mut self.noise {
            Some((rng, n)) => self.output + n.sample(rng),
            None => self.output,
        }
    }
    fn advance(&mut self, command: f64) {
        let u = command.clamp(self.command_limits.0, self.command_limits.1);
        let v = match &mut self.hysteresis {
            Some((m, s)) => m.step(s, u),
            None => u,
        };
        self.output = self.linear.step(v);
    }
    fn true_output(&self) -> f64 {
        self.output
    }
}
