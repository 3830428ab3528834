"""Dynamics in reference-point coordinates (Nikravesh 1988; Zhang & Zhang 2017, eq. 3-5): the
equation builder, the affine family of efforts, the closed-form n-RRR inverse dynamics and
the energy audit. Masses and constraint equations live in :class:`rrr4.mechanism.Model`."""
