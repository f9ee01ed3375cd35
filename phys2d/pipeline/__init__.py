"""The pipeline of one tick: the records its stages read and write (``records``), the stages
(``stages``), and the step that runs them, one by one or in one compiled call (``step``)."""
