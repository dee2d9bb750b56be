"""Generated evaluators (checked in; regenerate with ``eigentwist generate``)."""
