"""``labsim export``: a trace in a format other tools open (docs/mcap.md).

An application of its own: ``mcap_file`` writes a trace as an MCAP file that Foxglove and Rerun
open, with Foxglove's well-known schemas for the robots' poses, the world's walls and the
events, and every trace column as a channel to plot.
"""
