"""fleetnav."""
