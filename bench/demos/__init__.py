"""The experts ifo-bench trains, the demonstration pools recorded from them, and Minari in
and out."""
