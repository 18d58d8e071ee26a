"""gazed: keeps an active camera locked on a moving target."""

__version__ = "0.1.0"
