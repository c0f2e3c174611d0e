"""Human-readable numbers with units."""


def format_rate(rate_bps: float) -> str:
    """'12.34 Gbit/s', '412.0 Mbit/s', ..."""
    for scale, unit in ((1e9, "Gbit/s"), (1e6, "Mbit/s"), (1e3, "kbit/s")):
        if abs(rate_bps) >= scale:
            return f"{rate_bps / scale:.2f} {unit}"
    return f"{rate_bps:.1f} bit/s"
