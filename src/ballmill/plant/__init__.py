"""The whole plant around the mill: flowsheet (streams), equipment and operating costs, a
discounted cash flow to the minimum selling price of rTPA, and its uncertainty."""
