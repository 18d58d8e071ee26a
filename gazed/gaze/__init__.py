"""Gaze control: the saccade/pursuit state machine and where to point (DESIGN §7)."""
