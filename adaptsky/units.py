"""Human-readable numbers with units."""

RATE_UNITS = ((1e9, "Gbit/s"), (1e6, "Mbit/s"), (1e3, "kbit/s"))


def format_rate(rate_bps: float) -> str:
    """'12.34 Gbit/s', '412.0 Mbit/s', ..."""
    for scale, unit in RATE_UNITS:
        if abs(rate_bps) >= scale:
            return f"{rate_bps / scale:.2f} {unit}"
    return f"{rate_bps:.1f} bit/s"


def rate_unit(rates_bps: list[float]) -> tuple[float, str]:
    """One scale and unit that suits every rate of a table (by the largest)."""
    largest = max((abs(r) for r in rates_bps), default=0.0)
    for scale, unit in RATE_UNITS:
        if largest >= scale:
            return scale, unit
    return 1.0, "bit/s"


def format_rate_spread(mean_bps: float, std_bps: float) -> str:
    """'47.26 ± 0.31 Gbit/s': mean and spread in the mean's unit."""
    scale, unit = rate_unit([mean_bps])
    return f"{mean_bps / scale:.2f} ± {std_bps / scale:.2f} {unit}"


def plural(count: int, noun: str) -> str:
    """'1 seed', '3 seeds'."""
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def format_duration(seconds: float) -> str:
    """'42 s', '3 min 07 s', '2 h 05 min'."""
    minutes, secs = divmod(round(seconds), 60)
    hours, minutes = divmod(minutes, 60)
    if hours:
        return f"{hours} h {minutes:02d} min"
    return f"{minutes} min {secs:02d} s" if minutes else f"{secs} s"
