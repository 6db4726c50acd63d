"""Control laws for the two-link arm: computed torque, Mamdani fuzzy PD, FCM rule reduction."""
