//! Where command requests are answered: on the publisher thread, outside the control loop,
//! validated against the loop's published status; only valid commands reach the loop.

use jointctl_ipc::CommandResponse;

use crate::commands::{ArmCommand, CommandValidator};

/// Answers command requests: validates them against the loop's published status, queues the
/// valid ones for the loop, and waits for the loop to apply an enable or disable before it
/// answers (so that the next command is validated against the new state).
pub struct CommandDesk {
    validator: CommandValidator,
    period: std::time::Duration,
}

impl CommandDesk {
    /// A desk for a loop of this period.
    pub fn new(validator: CommandValidator, period_s: f64) -> Self {
        CommandDesk { validator, period: std::time::Duration::from_secs_f64(period_s) }
    }

    /// The answer to one request; a valid command is pushed into `queue` for the loop.
    pub fn answer(&mut self, request: &jointctl_ipc::CommandRequest, queue: &mut rtrb::Producer<ArmCommand>) -> CommandResponse {
        let (command, text) = match self.validator.validate(request) {
            Ok(ok) => ok,
            Err(reason) => return CommandResponse::new(false, &reason.to_string()),
        };
        if queue.push(command).is_err() {
            return CommandResponse::new(false, "the runtime's command queue is full; try again");
        }
        if let ArmCommand::Stop = command {
            self.validator.stop_queued();
        }
        if let ArmCommand::Enable { dof, enabled } = command
            && !self.wait_applied(|s| s.enabled(dof) == enabled)
        {
            return CommandResponse::new(true, &format!("{text}; queued, the loop has not applied it yet"));
        }
        CommandResponse::new(true, &text)
    }

    /// Waits up to five periods (and at least 20 ms) for the loop to publish a status where
    /// `applied` holds.
    fn wait_applied(&self, applied: impl Fn(&crate::status::LoopStatus) -> bool) -> bool {
        let status = self.validator.status();
        let end = std::time::Instant::now() + (self.period * 5).max(std::time::Duration::from_millis(20));
        loop {
            if applied(status) {
                return true;
            }
            if std::time::Instant::now() >= end || status.stopping() {
                return false;
            }
            std::thread::sleep(std::time::Duration::from_micros(500));
        }
    }
}
