"""Reports with figures: the paper's slider-yoke study (:mod:`.paper`, ``flexclear paper``) and the
mechanism reports (:mod:`.mechanisms`: ``flexclear spin-up``, ``slider-crank``, ``four-bar``)."""
