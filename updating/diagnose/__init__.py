"""What the nominal model gets wrong about a baseline test: model family, fit, ranked causes."""
