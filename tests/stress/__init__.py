"""The numerical stability suite: extreme scales, grazing rays, degenerate input, tolerances."""
