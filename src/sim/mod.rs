//! Simulation: the embedded virtual FTS, user plants, reference trajectories
//! and closed-loop runs through the runtime controller step.

pub mod closed_loop;
pub mod reference;
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
