"""The scan as the methods see it: points projected once onto a plane, with their scan lines,
their noise and the plane's choice (the first stage, below every method)."""
