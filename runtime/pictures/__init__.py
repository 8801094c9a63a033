"""Pictures of a finished run: ``labsim plot`` draws a trace as a map, a signals chart, a camera
strip or an animation (``driver`` picks by the output's suffix)."""
