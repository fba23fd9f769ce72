"""Pictures: scenes with paths and bodies, curvature profiles (PNG through matplotlib)."""
