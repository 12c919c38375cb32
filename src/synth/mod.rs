//! Controller and feedforward synthesis.

pub mod budget;
pub mod compliance;
pub mod composite;
pub mod dhinf;
pub mod ding22;
pub mod dob;
pub mod genplant;
pub mod h2;
pub mod hinf;
pub mod ilc;
pub mod mechanism;
pub mod mixsyn;
pub mod pid;
pub mod repetitive;
pub mod weights;
pub mod zpetc;
