//! Checks of the command line's private parts (argument rewriting, manual
//! pages, option names in messages, the loop plot's span). They live
//! beside the code they check, in `fts::cli`'s `checks` modules (compiled
//! with the `checks` feature), and run here like the library's checks
//! (`checks.rs`).

use fts::cli::internal_checks::{cli, loop_analysis, manual, names};

#[test]
fn negative_values_reach_their_option() {
    cli::negative_values_reach_their_option();
}

#[test]
fn one_file_named_by_two_result_options_is_refused() {
    cli::one_file_named_by_two_result_options_is_refused();
}

#[test]
fn one_manual_page_per_subcommand_each_roff() {
    manual::one_page_per_subcommand_each_roff();
}

#[test]
fn every_setting_is_the_id_of_an_option_of_its_command() {
    names::every_setting_is_the_id_of_an_option_of_its_command();
}

#[test]
fn messages_name_only_flags_of_their_command() {
    names::messages_name_only_flags_of_their_command();
}

#[test]
fn a_setting_is_named_as_typed() {
    names::a_setting_is_named_as_typed();
}

#[test]
fn flags_are_found_in_messages() {
    names::flags_are_found_in_messages();
}

#[test]
fn the_leaf_command_is_remembered() {
    names::the_leaf_command_is_remembered();
}

#[test]
fn the_mixsyn_loop_plot_spans_its_features_not_fourteen_decades() {
    loop_analysis::the_mixsyn_loop_plot_spans_its_features_not_fourteen_decades(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")),
    );
}
