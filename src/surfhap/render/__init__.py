"""Stateful processors with reset() and a block method: texture synthesis, drive laws, resampling, carrier, safety stage, shape renderer, grains."""
