"""Session-wide test setup."""

import signal

# A shell without job control (CI runners, `cmd &` in a script) starts background jobs with SIGINT ignored, and an
# ignored signal stays ignored across exec: the CLI processes these tests stop with Ctrl-C would never see it (the
# sweep ran to the end, `fleetnav zenoh` never exited). Python's own handler in the test process instead gives
# the processes it starts SIGINT's default disposition, as from a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
