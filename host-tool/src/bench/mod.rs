//! Benchmarks behind `gonio bench` and docs/PERFORMANCE.md: the evaluation
//! [`variants`] (speed against error), the slower [`study`] runs (readings against fit
//! error, fit time against error) and the [`replay_study`] on a real sweep, the three-component fit timed for the comparison
//! with scipy ([`versus`]), the multi-start's speed against its accuracy ([`starts`]),
//! a campaign's wall time against its CPU time and memory ([`campaign`]), the budget's
//! Monte Carlo cost ([`monte_carlo`]), their text
//! [`table`]s and the speed-against-error [`chart`].

pub mod campaign;
pub mod chart;
pub mod monte_carlo;
pub mod replay_study;
pub mod starts;
pub mod study;
pub mod table;
pub mod variants;
pub mod versus;

pub use campaign::{CampaignRow, CampaignStudy, campaign_study, default_threads};
pub use chart::speed_vs_error;
pub use monte_carlo::{MonteCarloCost, monte_carlo_cost, monte_carlo_line};
pub use replay_study::{ReplayStudy, replay_study};
pub use starts::{StartsRow, starts_study};
pub use study::{
    MemberRow, PlanResult, ScaleRow, StudyError, member_study, plan_study, scale_study,
};
pub use variants::{VariantResult, bench_params, dense_grid, eval_grid, eval_pairs, naive, run};
pub use versus::{Versus, VersusFit, check_start, fit_versus, parse_start};
