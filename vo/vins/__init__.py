"""Seed 002's monocular visual-inertial navigation (VINS-Mono framework) with adaptive covariance and an
adaptive M-estimator: front-end, pre-integration, initialisation, sliding-window factor graph, estimator."""
