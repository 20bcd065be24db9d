"""Seeds of a run's episodes: episode ``index`` of a run with base seed ``base_seed``."""

import numpy as np


def episode_seed(base_seed: int, index: int) -> int:
    """The seed of episode ``index`` of a run with ``base_seed``; any episode can be replayed
    alone with ``ServeDiagram.run(episode_seed(base_seed, index))``."""
    return int(np.random.SeedSequence([base_seed, index]).generate_state(1)[0])
