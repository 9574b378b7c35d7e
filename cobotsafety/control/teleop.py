"""Former home of ``HumanAwareTeleop``, now ``cobotsafety.control.human_aware`` (re-exported
here so that existing imports keep working)."""

from cobotsafety.control.human_aware import HumanAwareTeleop

__all__ = ["HumanAwareTeleop"]
