"""The package's exceptions: one base class, subclasses that say what went wrong."""


class CobotSafetyError(Exception):
    """Base class of every error raised by cobotsafety."""


class InfeasibleConstraintsError(CobotSafetyError, ValueError):
    """No velocity satisfies every half-space ``normals @ v >= bounds``."""


class RecordingError(CobotSafetyError, ValueError):
    """A recording (replay file, ROS bag, trial log) is corrupt; the message names file and record."""


class UnknownRobotError(CobotSafetyError, KeyError):
    """A robot name that is not supported; the message lists the known names."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class MotionLimitsError(CobotSafetyError, ValueError):
    """A robot's motion-limit table is missing, incomplete or invalid; the message names robot and joint."""


class PseudonymError(CobotSafetyError, ValueError):
    """A participant pseudonym that could not name a file safely, or one given twice."""


class TaskError(CobotSafetyError, RuntimeError):
    """A task that cannot be done on this robot (the campaign's pick-and-place path does not
    complete with nobody there); the message names robot and task."""


class CampaignError(CobotSafetyError, ValueError):
    """A campaign directory that holds another campaign's results; the message says which setting differs."""
