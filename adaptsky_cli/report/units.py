"""Human-readable numbers with units."""


def format_rate(rate_bps: float) -> str:
    """'12.34 Gbit/s', '412.0 Mbit/s', ..."""
    for scale, unit in ((1e9, "Gbit/s"), (1e6, "Mbit/s"), (1e3, "kbit/s")):
        if abs(rate_bps) >= scale:
            return f"{rate_bps / scale:.2f} {unit}"
    return f"{rate_bps:.1f} bit/s"


def rate_unit(rates_bps: list[float]) -> tuple[float, str]:
    """One scale and unit that suits every rate of a table (by the largest)."""
    largest = max((abs(r) for r in rates_bps), default=0.0)
    for scale, unit in ((1e9, "Gbit/s"), (1e6, "Mbit/s"), (1e3, "kbit/s")):
        if largest >= scale:
            return scale, unit
    return 1.0, "bit/s"
