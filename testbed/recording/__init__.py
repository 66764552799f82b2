"""Recording a run: the streamed trace file (.rrd) and reading it back, the recorder and its
streamed reductions, reference windows, the 3D scene, the live viewer, atomic file writes."""

import os

# A trace written without Rerun's footer (a long run, `recording_to`) is our documented choice:
# silence the warning Rerun prints for each such file, unless the user set RUST_LOG; and a viewer
# that goes away mid-run is said once at the end (testbed.recording.live_view), not once a flush by Rerun's
# gRPC client; a file sink's write error (a full disk) is said once by testbed.recording.rrd_file,
# naming the file, not by Rerun's file sink and encoder. Rerun reads it once, when first imported;
# it is taken out again so that processes started later (a viewer) do not inherit it.
_SILENCED = "RUST_LOG" not in os.environ
if _SILENCED:
    os.environ["RUST_LOG"] = ("warn,re_log_encoding::rrd::file_sink=off,re_log_encoding::rrd::encoder=off,"
                              "re_grpc_client=off,re_sdk::recording_stream=off")
import rerun  # noqa: E402,F401
if _SILENCED:
    del os.environ["RUST_LOG"]
