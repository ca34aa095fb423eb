//! Episodes: a world plus the opponent, the step of `step_mul` loops, rewards and the end
//! of the episode. The same `Env` serves MARL training loops, the CLI and the nodes.

mod episode;
mod epo;
mod observe;
mod options;
mod reward;
mod step;
mod text;

pub use episode::{BadFovActions, Env, EnvConfig, MAX_FOV_ACTIONS, Outcome, RewardMode, StepResult, check_fov_actions};
pub use observe::effects;
pub use options::{BadOption, EnvOptions};
pub use reward::DenseReward;
pub use text::describe;
