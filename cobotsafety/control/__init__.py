"""Human-aware motion: humans as moving protection zones, paper 2's potential field, ISO/TS 15066 SSM."""
