"""Recording a run: the streamed trace file (.rrd) and reading it back, the recorder and its
streamed reductions, reference windows, the 3D scene, the live viewer, atomic file writes.
Rerun's SDK comes from `testbed.recording.rerun_sdk` (its log filter set), imported only by
the modules that need it."""
