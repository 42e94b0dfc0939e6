"""Spectra and orders of gear-system responses: order spectra of steady-state records with mesh harmonics,
sidebands and shaft orders marked (:mod:`.spectrum`), the records of a simulated steady state (:mod:`.records`),
and the Campbell diagram's order lines and crossings (:mod:`.campbell`)."""
