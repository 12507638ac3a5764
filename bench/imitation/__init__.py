"""What imitation adds to RL: demonstrations, the discriminator, TCN's embedding and BCO's
inverse dynamics. Imports rl only."""
