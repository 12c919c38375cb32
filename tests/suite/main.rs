//! fts's integration tests, compiled as one test binary: one link of the
//! library and its dependencies instead of one per file, which is most of a
//! fresh clone's test build. Each file is a module named as before, so
//! `cargo test --test suite hinf_certified` runs one of them. The
//! allocation-counting tests live in their own binary (`tests/no_alloc.rs`),
//! because they install a global allocator.

mod common;
mod reference_cases;

mod analysis_oracle;
mod bad_input;
mod c_runtime;
mod c_runtime_multiaxis;
mod checks;
mod cli_bounds;
mod cli_hysteresis;
mod cli_identify_ct;
mod cli_identify_linear;
mod cli_inputs;
mod cli_loop;
mod cli_mechanism;
mod cli_records;
mod cli_response;
mod cli_robust;
mod cli_simulate;
mod cli_ss_controller;
mod cli_zpetc;
mod contour;
mod controller_consistency;
mod conversions;
mod ding22;
mod dob;
mod doc_transcripts;
mod exact_stability;
mod help_consistency;
mod hinf_certified;
mod hinf_near_integrator;
mod hinf_scaling;
mod hinf_slicot;
mod hysteresis_identify;
mod hysteresis_props;
mod hysteresis_rate;
mod learning;
mod li21_pattern;
mod li21_reference;
mod loop_margins;
mod loop_props;
mod mat_reader;
mod option_fuzz;
mod parser_fuzz;
mod pipeline_build;
mod pipeline_robust;
mod responses;
mod riccati_props;
mod robust_reference;
mod schur_props;
mod self_checks;
mod slicot_synth;
mod step_equivalence;
mod synth_corpus;
mod zeros_slicot;
mod zpetc_props;
