"""Point queries: closest points (closest.py), generalized winding numbers (winding.py), and the Morton order
large point batches are walked in (order.py)."""
