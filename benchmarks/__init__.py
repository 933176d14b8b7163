"""Speed and time-versus-error studies, run by ``make bench`` (never by the tests)."""
