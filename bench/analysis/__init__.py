"""Analysis: records -> one tidy frame -> normalized scores -> statistics, figures and reports.
Roles come from the records, never from an algorithm's name."""
