"""Vector fitting, order selection, passivity test and enforcement."""
