"""steam_ref: incremental sparse GP regression for continuous-time STEAM (Yan, Indelman, Boots)."""
