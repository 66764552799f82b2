"""Rerun's SDK, imported once with its log filter set: every module of the testbed takes `rr` and
`rrb` from here, so that Rerun is imported only by what writes, reads or shows a trace (a
command that does not, `testbed list` or `describe`, never pays its 0.7 s of import).

A trace written without Rerun's footer (a long run, `recording_to`) is our documented choice:
silence the warning Rerun prints for each such file, unless the user set RUST_LOG; and a viewer
that goes away mid-run is said once at the end (testbed.recording.live_view), not once a flush
by Rerun's gRPC client; a file sink's write error (a full disk) is said once by
testbed.recording.rrd_file, naming the file, not by Rerun's file sink and encoder. Rerun reads
RUST_LOG once, when first imported; it is taken out again so that processes started later (a
viewer) do not inherit it.
"""

import os
import sys

_SILENCED = "RUST_LOG" not in os.environ
if _SILENCED:
    os.environ["RUST_LOG"] = ("warn,re_log_encoding::rrd::file_sink=off,re_log_encoding::rrd::encoder=off,"
                              "re_grpc_client=off,re_sdk::recording_stream=off")
import rerun as rr  # noqa: E402
import rerun.blueprint as rrb  # noqa: E402
import rerun.chunk  # noqa: E402,F401  (the trace reader's RrdReader)
if _SILENCED:
    del os.environ["RUST_LOG"]


class _NoPandas:
    """An import finder that says pandas is not there."""

    def find_spec(self, name, path=None, target=None):
        if name == "pandas":
            raise ImportError("pandas is not asked for by a trace")


# Rerun turns each text (a trace's result document) into an Arrow array, and pyarrow first asks,
# once a process, whether pandas is installed, importing it (0.6 s of CPU, more than MuJoCo) to
# see whether the text is a pandas object. No trace holds one: unless pandas is loaded already,
# pyarrow's question is answered "no" here. pyarrow asks again, and imports pandas, for what
# needs it (`Table.to_pandas`); a pandas object given to pyarrow later is read as a sequence.
if "pandas" not in sys.modules:
    sys.meta_path.insert(0, _NoPandas())
    try:
        rr.TextDocument("", media_type="text/plain")
    finally:
        sys.meta_path.remove(next(f for f in sys.meta_path if isinstance(f, _NoPandas)))

__all__ = ["rr", "rrb"]
