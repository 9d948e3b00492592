"""Running clip jobs: the clip-level services without click (:mod:`.jobs`), the local process
pool (:mod:`.pool`), Dask clusters (:mod:`.cluster`) and the allocator's memory
(:mod:`.memory`)."""
