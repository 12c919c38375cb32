//! The library's checks of its private parts, gathered for the integration
//! suite (`tests/suite/checks.rs`), which runs each as one test. Every module
//! named here is a `checks` module beside the code it checks, compiled only
//! with the `checks` feature that `cargo test` turns on.

pub use crate::cli::checks as cli;
pub use crate::cli::loop_analysis::checks as cli_loop_analysis;
pub use crate::cli::manual::checks as cli_manual;
pub use crate::cli::names::checks as cli_names;
pub use crate::ident::arx::checks as ident_arx;
pub use crate::ident::correlation::checks as ident_correlation;
pub use crate::ident::ct::checks as ident_ct;
pub use crate::ident::ct::zoh::checks as ident_ct_zoh;
pub use crate::ident::data::checks as ident_data;
pub use crate::ident::excite::checks as ident_excite;
pub use crate::ident::freq::checks as ident_freq;
pub use crate::ident::hysteresis::gd::checks as ident_hysteresis_gd;
pub use crate::ident::hysteresis::identify::checks as ident_hysteresis_identify;
pub use crate::ident::hysteresis::inverse::checks as ident_hysteresis_inverse;
pub use crate::ident::hysteresis::lsq::checks as ident_hysteresis_lsq;
pub use crate::ident::hysteresis::model::checks as ident_hysteresis_model;
pub use crate::ident::hysteresis::operators::checks as ident_hysteresis_operators;
pub use crate::ident::hysteresis::solve::checks as ident_hysteresis_solve;
pub use crate::ident::linear::checks as ident_linear;
pub use crate::ident::ls::checks as ident_ls;
pub use crate::ident::metrics::checks as ident_metrics;
pub use crate::ident::oe::checks as ident_oe;
pub use crate::ident::periodic::checks as ident_periodic;
pub use crate::ident::structure::checks as ident_structure;
pub use crate::io::controller_file::checks as io_controller_file;
pub use crate::io::controller_file::multiaxis::checks as io_controller_file_multiaxis;
pub use crate::io::hysteresis_json::checks as io_hysteresis_json;
pub use crate::io::mat::checks as io_mat;
pub use crate::io::plot::checks as io_plot;
pub use crate::io::ss_json::checks as io_ss_json;
pub use crate::io::tf_json::checks as io_tf_json;
pub use crate::io::timeseries::checks as io_timeseries;
pub use crate::io::zpetc_json::checks as io_zpetc_json;
pub use crate::lti::accurate::checks as lti_accurate;
pub use crate::lti::balred::checks as lti_balred;
pub use crate::lti::c2d::checks as lti_c2d;
pub use crate::lti::convert::checks as lti_convert;
pub use crate::lti::exact_response::checks as lti_exact_response;
pub use crate::lti::filter::checks as lti_filter;
pub use crate::lti::freqresp::checks as lti_freqresp;
pub use crate::lti::lyapunov::checks as lti_lyapunov;
pub use crate::lti::margins::checks as lti_margins;
pub use crate::lti::model_check::checks as lti_model_check;
pub use crate::lti::norms::checks as lti_norms;
pub use crate::lti::poly::checks as lti_poly;
pub use crate::lti::response::checks as lti_response;
pub use crate::lti::riccati::checks as lti_riccati;
pub use crate::lti::roots::checks as lti_roots;
pub use crate::lti::ss::checks as lti_ss;
pub use crate::lti::stability::checks as lti_stability;
pub use crate::lti::stability::winding::checks as lti_stability_winding;
pub use crate::lti::tf::checks as lti_tf;
pub use crate::lti::zeros::checks as lti_zeros;
pub use crate::pipeline::hash::checks as pipeline_hash;
pub use crate::pipeline::manifest::checks as pipeline_manifest;
pub use crate::sim::closed_loop::checks as sim_closed_loop;
pub use crate::sim::contour::checks as sim_contour;
pub use crate::sim::disturbance::checks as sim_disturbance;
pub use crate::sim::path::checks as sim_path;
pub use crate::sim::reference::checks as sim_reference;
pub use crate::sim::reference::resample_checks as sim_reference_resample;
pub use crate::sim::scurve::checks as sim_scurve;
pub use crate::sim::virtual_fts::checks as sim_virtual_fts;
pub use crate::synth::budget::checks as synth_budget;
pub use crate::synth::compliance::checks as synth_compliance;
pub use crate::synth::composite::checks as synth_composite;
pub use crate::synth::ding22::checks as synth_ding22;
pub use crate::synth::dob::checks as synth_dob;
pub use crate::synth::hinf::central::checks as synth_hinf_central;
pub use crate::synth::ilc::checks as synth_ilc;
pub use crate::synth::mechanism::checks as synth_mechanism;
pub use crate::synth::pid::checks as synth_pid;
pub use crate::synth::repetitive::checks as synth_repetitive;
pub use crate::synth::weights::checks as synth_weights;
pub use crate::synth::zpetc::checks as synth_zpetc;
pub use crate::synth::zpetc::self_checks as synth_zpetc_self;
pub use crate::workflow::checks as workflow;
pub use crate::workflow::contour::checks as workflow_contour;
pub use crate::workflow::ding22::checks as workflow_ding22;
pub use crate::workflow::identify_ct::checks as workflow_identify_ct;
pub use crate::workflow::puu3::checks as workflow_puu3;
pub use crate::workflow::simulate::checks as workflow_simulate;
pub use crate::workflow::zpetc::checks as workflow_zpetc;

/// A deterministic white sequence on [0, 1) from `seed` (64-bit LCG, the
/// top 53 bits of each new state), for the library's checks and the
/// integration suite alike.
pub fn unit_uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}
