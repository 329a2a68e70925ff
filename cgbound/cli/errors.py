"""Errors of the command line: one line naming the flag, never a traceback (unless --debug)."""
import contextlib
import re


class UsageError(Exception):
    """A command-line argument that cannot be used; ``flag`` names it as the user typed it."""

    def __init__(self, flag, message):
        super().__init__(f"{flag}: {message}" if flag else message)
        self.flag = flag


#: the API's argument names and the flags that set them, so that an API error names what the user typed
API_FLAGS = {
    "body_force": "--gravity", "body_force_override": "--gravity-override", "shape": "--grid", "average": "--average", "width": "--width",
    "cutoff": "--cutoff", "radius": "--cutoff", "normalize": "--normalize", "fields": "--fields",
    "convention": "--convention", "time_average": "--time-average", "start": "--start", "stop": "--stop",
    "step": "--step", "pairs": "--pairs", "fstat_path": "--pairs", "restart_path": "--restart",
    "fixed_types": "--fixed-types", "fixed_ids": "--fixed-ids", "fixed": "--fixed-ids", "walls": "--walls",
    "masses": "--masses", "dt": "--dt", "dimension": "--dimension", "dim": "--dimension",
    "density": "--density", "pair_values": "--pair-values", "pair_compute": "--pair-compute",
    "wall_contacts": "--wall-contacts", "wall_values": "--wall-values", "wall_compute": "--wall-compute",
    "pair_style": "--pair-style", "species": "--species", "lower": "--lower", "upper": "--upper",
    "paths": "PATH", "check_forces": "--no-check-forces",
    "couple_stress_form": "--couple-stress-form",
}
API_FLAGS["kernel"] = "--kernel"        # e.g. a gradient field asked of the Heaviside kernel

_LEADING_NAME = re.compile(r"^([A-Za-z_][A-Za-z0-9_.]*): ")


_NO_FLAG = object()


#: flags whose API name also names values read from the data (a Snapshot's ``masses``): an error with that name is
#: the flag's only when the flag was given, else the data's
DATA_NAMED_FLAGS = {"--masses": "masses"}


@contextlib.contextmanager
def as_usage(default_flag=_NO_FLAG, args=None):
    """Turn the API's ValueError/TypeError into a UsageError naming the flag behind its argument
    (the message's leading ``name:``), else ``default_flag``; without a default, an error about no
    argument (the data itself) passes unchanged. With ``args`` (the parsed arguments), a name of
    DATA_NAMED_FLAGS whose flag was not given is the data's."""
    try:
        yield
    except (ValueError, TypeError, OverflowError) as exc:
        message = str(exc)
        match = _LEADING_NAME.match(message)
        flag = API_FLAGS.get(match.group(1)) if match else None
        if flag in DATA_NAMED_FLAGS and args is not None and getattr(args, DATA_NAMED_FLAGS[flag], None) is None:
            flag = None
        if flag is not None:
            raise UsageError(flag, message[match.end():]) from exc
        if default_flag is _NO_FLAG:
            raise
        raise UsageError(default_flag, message) from exc
