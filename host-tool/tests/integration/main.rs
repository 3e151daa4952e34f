//! The integration tests of `gonio`, in one binary (one link of the library): each
//! module runs the command as a user does, sharing [`util`].

mod util;

mod accuracy_bar;
mod bad_input;
mod budget_cli;
mod capture_pty;
mod crash_safety;
mod docs_examples;
mod eval_cli;
mod fault_injection;
mod fit_cli;
mod formats_cli;
mod golden;
mod honest_answers;
mod hostile;
mod live_view;
mod meta_cli;
mod module_graph;
mod ports_flash;
mod real_sweeps;
mod units_chain;
mod units_cli;
mod units_session;
mod until_cli;
mod wild_values;
