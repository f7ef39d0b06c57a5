"""Node groups built by code: the layered BRDF from stock Cycles/EEVEE nodes."""
