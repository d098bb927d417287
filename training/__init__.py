"""Training only: `petswarm train` (train), its config, the vector-env wrappers, the warm start, the callback and the policy export."""
